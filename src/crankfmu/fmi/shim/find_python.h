/* What the shim's two files share (fmu_shim.c, find_python.c); hidden: the shim's library
 * exports the FMI functions only. */
#ifndef FIND_PYTHON_H
#define FIND_PYTHON_H

#include "fmi2Functions.h"

#define SHIM_INTERNAL __attribute__((visibility("hidden")))

/* a message to the host's logger with fmi2Error status, whatever its logging setting (fmu_shim.c) */
SHIM_INTERNAL void host_log(const fmi2CallbackFunctions* cb, fmi2String name, const char* message, const char* detail);
/* a Python with numpy found, its libpython loaded globally and started; 0 (the host told why)
 * when none is found (find_python.c) */
SHIM_INTERNAL int find_and_start_python(const char* resources, const fmi2CallbackFunctions* cb, fmi2String name);

#endif
