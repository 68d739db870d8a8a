/* A plain C co-simulation host for the tests: loads an extracted FMI 2.0 FMU with
 * dlopen(RTLD_LOCAL) as C/C++ masters do, instantiates it, optionally sets real variables,
 * steps it and prints a real output, every call's status and the step loop's wall time.
 *
 *   fmu_driver DIR MODEL_ID GUID STEPS STEP_SIZE OUT_VR [VR=VALUE ...]
 *
 * Exit code: 0 when every call returned fmi2OK, 1 when a call returned another status (printed),
 * 2 when the FMU could not be loaded or instantiated. With FMU_DRIVER_NO_FREE=1 in the
 * environment it exits without fmi2Terminate and fmi2FreeInstance (a host that dies with the
 * instance alive), and with FMU_DRIVER_LOGGING=0 it instantiates with loggingOn = fmi2False.
 * With FMU_DRIVER_THREAD=1 the steps are made on a thread of their own, as a master's worker
 * thread makes them (ecos: a TBB pool), and the minor page faults of that thread during the
 * steps are printed (step_page_faults=N).
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <pthread.h>
#include <sys/resource.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2Functions.h"
#include "host_logger.h"


/* the step loop, on the calling thread or a thread of its own */
typedef struct {
    fmi2DoStepTYPE* step;
    fmi2Component c;
    int steps;
    double h, t;
    fmi2Status status;
    long page_faults;
} Steps;

static void* run_steps(void* arg)
{
    Steps* r = (Steps*)arg;
    struct rusage before, after;
    getrusage(RUSAGE_THREAD, &before);
    r->status = fmi2OK;
    for (int k = 0; k < r->steps; k++) {
        r->status = r->step(r->c, r->t, r->h, fmi2True);
        if (r->status != fmi2OK) break;
        r->t = (k + 1) * r->h;
    }
    getrusage(RUSAGE_THREAD, &after);
    r->page_faults = after.ru_minflt - before.ru_minflt;
    return NULL;
}

#define LOAD(f)                                                                  \
    f##TYPE* f = (f##TYPE*)dlsym(lib, #f);                                       \
    if (!f) {                                                                    \
        printf("missing symbol %s\n", #f);                                       \
        return 2;                                                                \
    }

int main(int argc, char** argv)
{
    if (argc < 7) {
        fprintf(stderr, "usage: %s DIR MODEL_ID GUID STEPS STEP_SIZE OUT_VR [VR=VALUE ...]\n", argv[0]);
        return 2;
    }
    const char* dir = argv[1];
    const char* model = argv[2];
    const char* guid = argv[3];
    int steps = atoi(argv[4]);
    double h = atof(argv[5]);
    fmi2ValueReference out_vr = (fmi2ValueReference)atoi(argv[6]);

    char path[4096], uri[4200];
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", dir, model);
    snprintf(uri, sizeof uri, "file://%s/resources", dir);
    void* lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        printf("dlopen failed: %s\n", dlerror());
        return 2;
    }
    LOAD(fmi2Instantiate)
    LOAD(fmi2SetupExperiment)
    LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode)
    LOAD(fmi2SetReal)
    LOAD(fmi2GetReal)
    LOAD(fmi2DoStep)
    LOAD(fmi2Terminate)
    LOAD(fmi2FreeInstance)

    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    const char* logging = getenv("FMU_DRIVER_LOGGING");
    fmi2Boolean logging_on = (logging && strcmp(logging, "0") == 0) ? fmi2False : fmi2True;
    fmi2Component c = fmi2Instantiate("c-host", fmi2CoSimulation, guid, uri, &cb, fmi2False, logging_on);
    if (!c) {
        printf("fmi2Instantiate returned NULL\n");
        return 2;
    }
    int bad = 0;
    fmi2Status s = fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
    printf("status fmi2SetupExperiment %d\n", (int)s);
    bad |= s != fmi2OK;
    s = fmi2EnterInitializationMode(c);
    printf("status fmi2EnterInitializationMode %d\n", (int)s);
    bad |= s != fmi2OK;
    for (int i = 7; i < argc; i++) {
        fmi2ValueReference vr = (fmi2ValueReference)atoi(argv[i]);
        const char* eq = strchr(argv[i], '=');
        fmi2Real value = eq ? atof(eq + 1) : 0.0;
        s = fmi2SetReal(c, &vr, 1, &value);
        printf("status fmi2SetReal %u=%g %d\n", vr, value, (int)s);
        bad |= s != fmi2OK;
    }
    s = fmi2ExitInitializationMode(c);
    printf("status fmi2ExitInitializationMode %d\n", (int)s);
    bad |= s != fmi2OK;
    Steps run = {fmi2DoStep, c, steps, h, 0.0, fmi2OK, 0};
    const char* threaded = getenv("FMU_DRIVER_THREAD");
    struct timespec started, ended;
    clock_gettime(CLOCK_MONOTONIC, &started);
    if (threaded && strcmp(threaded, "1") == 0) {
        pthread_t worker;
        if (pthread_create(&worker, NULL, run_steps, &run) != 0 || pthread_join(worker, NULL) != 0) {
            printf("cannot run the steps on a thread\n");
            return 2;
        }
        printf("step_page_faults=%ld\n", run.page_faults);
    } else {
        run_steps(&run);
    }
    clock_gettime(CLOCK_MONOTONIC, &ended);
    double t = run.t;
    if (run.status != fmi2OK) {
        printf("status fmi2DoStep at t=%.17g %d\n", t, (int)run.status);
        bad = 1;
    }
    /* the step loop's wall time (benchmarks/speed.py: the native FMU's cost per step in a C host) */
    printf("steps_seconds=%.9e\n", (double)(ended.tv_sec - started.tv_sec) + 1e-9 * (double)(ended.tv_nsec - started.tv_nsec));
    fmi2Real value = 0.0;
    s = fmi2GetReal(c, &out_vr, 1, &value);
    printf("status fmi2GetReal %d\n", (int)s);
    printf("result t=%.17g value=%.17g\n", t, value);
    const char* no_free = getenv("FMU_DRIVER_NO_FREE");
    if (!(no_free && strcmp(no_free, "1") == 0)) {
        fmi2Terminate(c);
        fmi2FreeInstance(c);
    }
    return bad ? 1 : 0;
}
