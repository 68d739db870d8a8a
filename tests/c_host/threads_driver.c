/* Many instances of one native FMI 2.0 FMU in one process, on several threads (issue 38): each
 * instance gets its own geometry (the crank length and the flywheel) before initialisation, so
 * each builds its own tables from the C mechanism model when initialisation ends, then steps.
 * The designs are run once on one thread, then again spread over THREADS threads at once; the
 * crank speeds reached must be equal bit for bit. Built with -fsanitize=thread (the FMU's
 * sources too) it also shows that the instances share nothing they write.
 *
 *   threads_driver LIBRARY GUID VR_L1 VR_J_FLYWHEEL VR_OMEGA1 THREADS INSTANCES STEPS
 *
 * Prints "identical N" (N designs) and exits 0, or the first difference and exits 1; 2 when the
 * FMU cannot be loaded or a call fails. */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "host_library.h"

static fmi2InstantiateTYPE* instantiate;
static fmi2FreeInstanceTYPE* free_instance;
static fmi2SetupExperimentTYPE* setup;
static fmi2EnterInitializationModeTYPE* enter;
static fmi2ExitInitializationModeTYPE* exit_init;
static fmi2SetRealTYPE* set_real;
static fmi2GetRealTYPE* get_real;
static fmi2DoStepTYPE* do_step;
static const char* guid;
static const char* resources;      /* the FMU's resources, a file: URI: its model file is there */
static fmi2ValueReference vr_l1, vr_j, vr_omega;
static int instances, steps;

static void quiet(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                  fmi2String message, ...)
{
    (void)env; (void)category;
    if (status != fmi2OK) fprintf(stderr, "[%s] %d: %s\n", name, (int)status, message);
}

/* design k: a crank 0.19 to 0.21 m and a flywheel 1 to 2 kg.m2 */
static void design(int k, int total, double* l1, double* J)
{
    *l1 = 0.19 + 0.02 * k / (total > 1 ? total - 1 : 1);
    *J = 1.0 + (double)(k % 7) / 6.0;
}

/* run designs first .. first + count - 1 into omega[]; 0 or 2 on a failed call */
static int run(int first, int count, int total, double* omega)
{
    fmi2CallbackFunctions callbacks = {quiet, calloc, free, NULL, NULL};
    for (int k = first; k < first + count; k++) {
        char name[32];
        snprintf(name, sizeof name, "design%d", k);
        fmi2Component c = instantiate(name, fmi2CoSimulation, guid, resources, &callbacks, fmi2False, fmi2False);
        if (!c) return 2;
        double values[2];
        design(k, total, &values[0], &values[1]);
        fmi2ValueReference vrs[2] = {vr_l1, vr_j};
        if (setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK || enter(c) != fmi2OK ||
            set_real(c, vrs, 2, values) != fmi2OK || exit_init(c) != fmi2OK)
            return 2;
        double t = 0.0;
        for (int i = 0; i < steps; i++, t += 1e-3)
            if (do_step(c, t, 1e-3, fmi2True) != fmi2OK) return 2;
        if (get_real(c, &vr_omega, 1, &omega[k]) != fmi2OK) return 2;
        free_instance(c);
    }
    return 0;
}

typedef struct {
    int first, count, total, status;
    double* omega;
} Work;

static void* worker(void* arg)
{
    Work* w = (Work*)arg;
    w->status = run(w->first, w->count, w->total, w->omega);
    return NULL;
}

int main(int argc, char** argv)
{
    if (argc != 10) {
        fprintf(stderr, "usage: %s LIBRARY GUID VR_L1 VR_J_FLYWHEEL VR_OMEGA1 THREADS INSTANCES STEPS RESOURCES_URI\n", argv[0]);
        return 2;
    }
    Library lib = open_library(argv[1]);
    if (!lib) return 2;
    guid = argv[2];
    vr_l1 = (fmi2ValueReference)atoi(argv[3]);
    vr_j = (fmi2ValueReference)atoi(argv[4]);
    vr_omega = (fmi2ValueReference)atoi(argv[5]);
    int threads = atoi(argv[6]);
    instances = atoi(argv[7]);
    steps = atoi(argv[8]);
    resources = argv[9];
    instantiate = (fmi2InstantiateTYPE*)symbol(lib, "fmi2Instantiate");
    free_instance = (fmi2FreeInstanceTYPE*)symbol(lib, "fmi2FreeInstance");
    setup = (fmi2SetupExperimentTYPE*)symbol(lib, "fmi2SetupExperiment");
    enter = (fmi2EnterInitializationModeTYPE*)symbol(lib, "fmi2EnterInitializationMode");
    exit_init = (fmi2ExitInitializationModeTYPE*)symbol(lib, "fmi2ExitInitializationMode");
    set_real = (fmi2SetRealTYPE*)symbol(lib, "fmi2SetReal");
    get_real = (fmi2GetRealTYPE*)symbol(lib, "fmi2GetReal");
    do_step = (fmi2DoStepTYPE*)symbol(lib, "fmi2DoStep");
    if (!instantiate || !free_instance || !setup || !enter || !exit_init || !set_real || !get_real || !do_step)
        return 2;
    int total = threads * instances;
    double* alone = calloc((size_t)total, sizeof(double));
    double* together = calloc((size_t)total, sizeof(double));
    if (run(0, total, total, alone) != 0) return 2;
    pthread_t* ids = calloc((size_t)threads, sizeof(pthread_t));
    Work* work = calloc((size_t)threads, sizeof(Work));
    for (int t = 0; t < threads; t++) {
        work[t] = (Work){t * instances, instances, total, 0, together};
        pthread_create(&ids[t], NULL, worker, &work[t]);
    }
    for (int t = 0; t < threads; t++) {
        pthread_join(ids[t], NULL);
        if (work[t].status) return 2;
    }
    for (int k = 0; k < total; k++)
        if (memcmp(&alone[k], &together[k], sizeof(double)) != 0) {
            printf("design %d: %.17g alone, %.17g on %d threads\n", k, alone[k], together[k], threads);
            return 1;
        }
    printf("identical %d (omega1 %.6f to %.6f rad/s)\n", total, alone[0], alone[total - 1]);
    return 0;
}
