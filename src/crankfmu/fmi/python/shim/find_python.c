/* The shim's Python (fmu_shim.c): in a process without Python (a C or C++ host) it picks an
 * interpreter, in this order:
 *   1. $CRANKFMU_PYTHON: a python executable, or a libpython*.so used as it is;
 *   2. the python executable the FMU was built with (resources/python_env.txt), if it exists;
 *   3. python3 on PATH.
 * An executable is asked (a child process) for its shared libpython and its sys.path, and must
 * import numpy; the first that does is loaded. When none does, fmi2Instantiate fails with a
 * message that lists what was tried and the command that fixes it. */
#define _GNU_SOURCE

#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "find_python.h"

#define PROBE                                                                                          \
    "import sys, os, sysconfig; import numpy; v = sysconfig.get_config_var; "                         \
    "print(\"LIBPYTHON\", os.path.join(v(\"LIBDIR\") or \"\", v(\"INSTSONAME\") or v(\"LDLIBRARY\") or \"\")); " \
    "print(\"VERSION\", sys.version.split()[0]); [print(\"PATH\", p) for p in sys.path if p]; print(\"OK\")"

typedef struct {
    char libpython[4096];
    char version[64];
    char paths[32768];      /* sys.path entries, one per line */
} Probe;

/* ask the python executable `exe`; 1 when it has numpy and a shared libpython */
static int probe_python(const char* exe, Probe* out, char* why, size_t n)
{
    char cmd[8192], line[4096];
    if (strchr(exe, '\'')) {
        snprintf(why, n, "its path has a quote");
        return 0;
    }
    snprintf(cmd, sizeof cmd, "'%s' -c '%s' 2>&1", exe, PROBE);
    FILE* f = popen(cmd, "r");
    if (!f) {
        snprintf(why, n, "cannot run it");
        return 0;
    }
    int ok = 0;
    size_t used = 0;
    out->libpython[0] = out->version[0] = out->paths[0] = '\0';
    snprintf(why, n, "no answer");
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = '\0';
        if (strncmp(line, "LIBPYTHON ", 10) == 0) snprintf(out->libpython, sizeof out->libpython, "%s", line + 10);
        else if (strncmp(line, "VERSION ", 8) == 0) snprintf(out->version, sizeof out->version, "%.60s", line + 8);
        else if (strncmp(line, "PATH ", 5) == 0) {
            size_t len = strlen(line + 5);
            if (used + len + 2 < sizeof out->paths) {
                memcpy(out->paths + used, line + 5, len);
                used += len;
                out->paths[used++] = '\n';
                out->paths[used] = '\0';
            }
        } else if (strcmp(line, "OK") == 0) ok = 1;
        else if (line[0]) snprintf(why, n, "%.1000s", line);   /* the last error line */
    }
    int status = pclose(f);
    if (!ok || status != 0) return 0;
    if (access(out->libpython, R_OK) != 0) {
        snprintf(why, n, "Python %s has no shared libpython (%s is missing; Debian: apt-get install libpython%.4s)",
                 out->version, out->libpython, out->version);
        return 0;
    }
    return 1;
}

static void build_executable(const char* resources, char* out, size_t n)
{
    char file[4096], line[4096];
    out[0] = '\0';
    snprintf(file, sizeof file, "%s/python_env.txt", resources);
    FILE* f = fopen(file, "r");
    if (!f) return;
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = '\0';
        if (strncmp(line, "executable=", 11) == 0) snprintf(out, n, "%s", line + 11);
    }
    fclose(f);
}

/* load libpython globally, start it, add the probe's sys.path; 1 on success */
static int start_python(const char* libpython, const char* paths, char* message, size_t size)
{
    if (!dlopen(libpython, RTLD_NOW | RTLD_GLOBAL)) {
        snprintf(message, size, "cannot load libpython: %s", dlerror());
        return 0;
    }
    void (*initialize)(int) = (void (*)(int))dlsym(RTLD_DEFAULT, "Py_InitializeEx");
    void* (*release_gil)(void) = (void* (*)(void))dlsym(RTLD_DEFAULT, "PyEval_SaveThread");
    int (*run)(const char*) = (int (*)(const char*))dlsym(RTLD_DEFAULT, "PyRun_SimpleString");
    if (!initialize || !release_gil || !run) {
        snprintf(message, size, "libpython lacks Py_InitializeEx, PyEval_SaveThread or PyRun_SimpleString: %s", libpython);
        return 0;
    }
    initialize(0);      /* 0: leave the host's signal handlers alone */
    if (paths && paths[0]) {
        /* the interpreter's own sys.path plus the probed one's (a virtual environment's
         * site-packages), passed as a Python literal with every byte escaped */
        size_t n = strlen(paths);
        char* code = (char*)malloc(4 * n + 256);
        if (code) {
            size_t j = (size_t)sprintf(code, "import sys\nfor _p in b'");
            for (size_t i = 0; i < n; i++) j += (size_t)sprintf(code + j, "\\x%02x", (unsigned char)paths[i]);
            sprintf(code + j, "'.decode().splitlines():\n    _p not in sys.path and sys.path.append(_p)\n");
            run(code);
            free(code);
        }
    }
    release_gil();      /* pythonfmu takes the GIL per call, from any thread */
    return 1;
}

int find_and_start_python(const char* resources, char* message, size_t size)
{
    char tried[8192] = "", why[1024], built[4096];
    size_t used = 0;
    static Probe probe;
    const char* env = getenv("CRANKFMU_PYTHON");
    const char* candidates[3] = {NULL, NULL, "python3"};
    const char* labels[3] = {"$CRANKFMU_PYTHON", "the building Python", "python3 on PATH"};
    if (env && env[0]) {
        if (strstr(env, ".so")) return start_python(env, NULL, message, size);      /* a libpython named directly */
        candidates[0] = env;
    }
    build_executable(resources, built, sizeof built);
    if (built[0] && access(built, X_OK) == 0) candidates[1] = built;
    else if (built[0]) used += (size_t)snprintf(tried + used, sizeof tried - used, "\n  the building Python %s: not on this machine", built);
    for (int k = 0; k < 3; k++) {
        if (!candidates[k]) continue;
        if (probe_python(candidates[k], &probe, why, sizeof why)) return start_python(probe.libpython, probe.paths, message, size);
        if (used < sizeof tried)
            used += (size_t)snprintf(tried + used, sizeof tried - used, "\n  %s (%s): %s", labels[k], candidates[k], why);
    }
    snprintf(message, size,
             "no Python with numpy found for this FMU (Linux x86_64, Python 3.10 to 3.13 with a shared libpython). "
             "Tried:%s\nFix: python3 -m pip install numpy (or set CRANKFMU_PYTHON to a python executable that has numpy)",
             tried);
    return 0;
}
