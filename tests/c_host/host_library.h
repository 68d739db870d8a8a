/* The test hosts' loading of an FMU's binary (system_driver.c, fmu3_driver.c): dlopen with
 * RTLD_LOCAL as C/C++ masters do, or LoadLibrary on Windows (the hosts compiled with MinGW, run
 * under wine). SUFFIX is the binary's file ending. */
#ifndef HOST_LIBRARY_H
#define HOST_LIBRARY_H

#ifdef _WIN32
#include <windows.h>
#define SUFFIX ".dll"
typedef HMODULE Library;
static Library open_library(const char* path) { return LoadLibraryA(path); }
static void* symbol(Library lib, const char* name) { return (void*)GetProcAddress(lib, name); }
#else
#include <dlfcn.h>
#define SUFFIX ".so"
typedef void* Library;
static Library open_library(const char* path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void* symbol(Library lib, const char* name) { return dlsym(lib, name); }
#endif

#endif
