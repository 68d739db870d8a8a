/* The Python the shim (fmu_shim.c) brings into a host without one (find_python.c). Hidden: the
 * shim's library exports the FMI functions only. */
#ifndef FIND_PYTHON_H
#define FIND_PYTHON_H

#include <stddef.h>

/* a Python with numpy found, its libpython loaded globally and the interpreter started: 1; else 0
 * and why in message (what was tried, and the command that fixes it) */
__attribute__((visibility("hidden"))) int find_and_start_python(const char* resources, char* message, size_t size);

#endif
