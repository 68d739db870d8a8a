/* A plain C host for FMI 3.0 Co-Simulation FMUs in the tests: loads an extracted FMU's binary for
 * the platform it was compiled for (x86_64-linux, aarch64-linux with dlopen; x86_64-windows with
 * LoadLibrary, under wine), instantiates it, optionally sets Float64 variables in initialisation
 * mode, steps it and prints one output after every step.
 *
 *   fmu3_driver DIR MODEL_ID TOKEN STEPS STEP_SIZE OUT_VR [VR=VALUE ...]
 *
 * Prints "row t,value" after each step (%.17g), every message the FMU logs as "log ...", a failed
 * call as "status CALL STATUS". Exit code: 0 when every call returned fmi3OK, 1 when one did not,
 * 2 when the FMU could not be loaded or instantiated. FMU_DRIVER_LOGGING=0 instantiates it with
 * loggingOn = false; FMU_DRIVER_EVENTS=1 with eventModeUsed and earlyReturnAllowed (an early
 * return is printed as "early t", and the step then continues from there); FMU_DRIVER_ROWS=0
 * prints no rows; FMU_DRIVER_NO_FREE=1 exits without fmi3Terminate and fmi3FreeInstance. The
 * step loop's wall time ends the output (steps_seconds=, not on Windows).
 */
#define _POSIX_C_SOURCE 200809L     /* clock_gettime with -std=c99 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "host_library.h"
#ifndef _WIN32
#include <time.h>
#endif
#if defined(_WIN32)
#define PLATFORM "x86_64-windows"
#elif defined(__aarch64__)
#define PLATFORM "aarch64-linux"
#else
#define PLATFORM "x86_64-linux"
#endif

#include "fmi3Functions.h"

static void log_message(fmi3InstanceEnvironment environment, fmi3Status status, fmi3String category,
                        fmi3String message)
{
    (void)environment;
    printf("log status=%d category=%s: %s\n", (int)status, category ? category : "", message ? message : "");
}

#define LOAD(type, name)                                   \
    type* name = (type*)symbol(lib, #name);                \
    if (!name) {                                           \
        printf("missing symbol %s\n", #name);              \
        return 2;                                          \
    }

int main(int argc, char** argv)
{
    if (argc < 7) {
        fprintf(stderr, "usage: %s DIR MODEL_ID TOKEN STEPS STEP_SIZE OUT_VR [VR=VALUE ...]\n", argv[0]);
        return 2;
    }
    const char* dir = argv[1];
    int steps = atoi(argv[4]);
    double h = atof(argv[5]);
    fmi3ValueReference out_vr = (fmi3ValueReference)atoi(argv[6]);
    char path[4096], resources[4200];
    snprintf(path, sizeof path, "%s/binaries/" PLATFORM "/%s" SUFFIX, dir, argv[2]);
    snprintf(resources, sizeof resources, "%s/resources/", dir);
    Library lib = open_library(path);
    if (!lib) {
        printf("cannot load %s\n", path);
        return 2;
    }
    LOAD(fmi3InstantiateCoSimulationTYPE, fmi3InstantiateCoSimulation)
    LOAD(fmi3EnterInitializationModeTYPE, fmi3EnterInitializationMode)
    LOAD(fmi3ExitInitializationModeTYPE, fmi3ExitInitializationMode)
    LOAD(fmi3EnterStepModeTYPE, fmi3EnterStepMode)
    LOAD(fmi3UpdateDiscreteStatesTYPE, fmi3UpdateDiscreteStates)
    LOAD(fmi3EnterEventModeTYPE, fmi3EnterEventMode)
    LOAD(fmi3SetFloat64TYPE, fmi3SetFloat64)
    LOAD(fmi3GetFloat64TYPE, fmi3GetFloat64)
    LOAD(fmi3DoStepTYPE, fmi3DoStep)
    LOAD(fmi3GetOutputDerivativesTYPE, fmi3GetOutputDerivatives)
    LOAD(fmi3GetDirectionalDerivativeTYPE, fmi3GetDirectionalDerivative)
    LOAD(fmi3GetAdjointDerivativeTYPE, fmi3GetAdjointDerivative)
    LOAD(fmi3TerminateTYPE, fmi3Terminate)
    LOAD(fmi3FreeInstanceTYPE, fmi3FreeInstance)

    const char* logging = getenv("FMU_DRIVER_LOGGING");
    const char* events = getenv("FMU_DRIVER_EVENTS");
    int with_events = events && strcmp(events, "1") == 0;
    const char* rows = getenv("FMU_DRIVER_ROWS");
    int quiet = rows && strcmp(rows, "0") == 0;
    fmi3Instance c = fmi3InstantiateCoSimulation("c-host", argv[3], resources, fmi3False,
                                                 !(logging && strcmp(logging, "0") == 0), with_events, with_events,
                                                 NULL, 0, NULL, log_message, NULL);
    if (!c) {
        printf("fmi3InstantiateCoSimulation returned NULL\n");
        return 2;
    }
    int bad = 0;
    fmi3Status s = fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0);
    if (s != fmi3OK) printf("status fmi3EnterInitializationMode %d\n", (int)s), bad = 1;
    for (int i = 7; i < argc; i++) {
        fmi3ValueReference vr = (fmi3ValueReference)atoi(argv[i]);
        const char* eq = strchr(argv[i], '=');
        fmi3Float64 value = eq ? atof(eq + 1) : 0.0;
        s = fmi3SetFloat64(c, &vr, 1, &value, 1);
        if (s != fmi3OK) printf("status fmi3SetFloat64 %u=%g %d\n", (unsigned)vr, value, (int)s), bad = 1;
    }
    s = fmi3ExitInitializationMode(c);
    if (s != fmi3OK) printf("status fmi3ExitInitializationMode %d\n", (int)s), bad = 1;
    fmi3Boolean need, terminate, nominals, values, next_defined, early;
    fmi3Float64 next, last;
    if (with_events && !bad) {
        fmi3UpdateDiscreteStates(c, &need, &terminate, &nominals, &values, &next_defined, &next);
        fmi3EnterStepMode(c);
    }
    double t = 0.0;
#ifndef _WIN32
    struct timespec started, ended;
    clock_gettime(CLOCK_MONOTONIC, &started);
#endif
    for (int k = 0; k < steps && !bad; k++) {
        double target = (k + 1) * h;
        while (!bad && t < target) {
            s = fmi3DoStep(c, t, target - t, fmi3True, &need, &terminate, &early, &last);
            if (s != fmi3OK) {
                printf("status fmi3DoStep at t=%.17g %d\n", t, (int)s);
                bad = 1;
                break;
            }
            if (early) printf("early %.17g\n", last);
            t = early ? last : target;
            if (need) {
                fmi3EnterEventMode(c);
                fmi3UpdateDiscreteStates(c, &need, &terminate, &nominals, &values, &next_defined, &next);
                fmi3EnterStepMode(c);
            }
        }
        fmi3Float64 value = 0.0;
        s = fmi3GetFloat64(c, &out_vr, 1, &value, 1);
        if (s != fmi3OK) printf("status fmi3GetFloat64 %d\n", (int)s), bad = 1;
        if (!quiet) printf("row %.17g,%.17g\n", t, value);
    }
    /* what a master couples with, at the last communication point: the output's first and second
     * time derivatives, and its directional and adjoint derivative with respect to itself (a state);
     * an FMU that offers none (a rod string) refuses them, which is no failure of the run */
    if (!bad) {
        fmi3ValueReference both[2] = {out_vr, out_vr};
        fmi3Int32 orders[2] = {1, 2};
        fmi3Float64 rates[2] = {0.0, 0.0}, seed = 1.0, directional = 0.0, adjoint = 0.0;
        s = fmi3GetOutputDerivatives(c, both, 2, orders, rates, 2);
        if (s == fmi3OK) s = fmi3GetDirectionalDerivative(c, &out_vr, 1, &out_vr, 1, &seed, 1, &directional, 1);
        if (s == fmi3OK) s = fmi3GetAdjointDerivative(c, &out_vr, 1, &out_vr, 1, &seed, 1, &adjoint, 1);
        if (s != fmi3OK) printf("status derivatives %d\n", (int)s);
        else printf("derivatives %.17g,%.17g,%.17g,%.17g\n", rates[0], rates[1], directional, adjoint);
    }
#ifndef _WIN32
    /* the step loop's wall time (benchmarks/fmi3_step.py: a step against the FMI 2.0 FMU's) */
    clock_gettime(CLOCK_MONOTONIC, &ended);
    printf("steps_seconds=%.9e\n", (double)(ended.tv_sec - started.tv_sec) + 1e-9 * (double)(ended.tv_nsec - started.tv_nsec));
#endif
    const char* no_free = getenv("FMU_DRIVER_NO_FREE");
    if (!(no_free && strcmp(no_free, "1") == 0)) {       /* else: a host that dies with the instance alive */
        fmi3Terminate(c);
        fmi3FreeInstance(c);
    }
    return bad ? 1 : 0;
}
