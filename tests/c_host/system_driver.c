/* A small fixed-step co-simulation master in plain C for the tests: the FMUs of a system (an SSP's
 * components, extracted), its parameter values, its connections and a fixed communication step,
 * read from a plan file; built for Linux (dlopen) and with MinGW for Windows (LoadLibrary), where
 * it runs the FMUs' win64 DLLs under wine. Each step reads every connected output, sets every
 * connected input, then steps every FMU from t to t + h (a Jacobi master, as libcosim's fixed-step
 * algorithm); in initialisation mode the connections are propagated twice, so that an output that
 * depends on a connected input (a cushion's force on the press's ram position) sees it.
 *
 *   system_driver PLAN
 *
 * PLAN, one item per line (names without spaces; VR a value reference):
 *   fmu NAME DIR MODEL_ID GUID      an extracted FMU: DIR/binaries/<linux64|win64>/MODEL_ID.<so|dll>
 *   set NAME VR VALUE               a parameter's value, set in initialisation mode
 *   connect NAME VR NAME VR         an output of the first to an input of the second
 *   record NAME VR                  a column of the output
 *   step H                          the communication step (s)
 *   stop T                          the end time (s)
 *   extrapolate                     each connected input also gets its output's first derivative
 *                                   (fmi2GetRealOutputDerivatives -> fmi2SetRealInputDerivatives):
 *                                   a line over the step, as PyFMI's and OMSimulator's extrapolation
 *   directional NAME VR VR          at the end, d(first VR)/d(second VR) by fmi2GetDirectionalDerivative,
 *                                   printed as "directional NAME VR VR VALUE"
 *
 * Prints "columns t,NAME.VR,..." then one line "row t,v,..." per communication point (%.17g),
 * every FMU's log line as "log ...", a failed call as "status CALL NAME STATUS", and exits with 0
 * when every call returned fmi2OK, 1 when one did not, 2 when the plan or an FMU cannot be loaded.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "host_library.h"
#ifdef _WIN32
#define BINARIES "win64"
#else
#define BINARIES "linux64"
#endif

#include "fmi2Functions.h"
#include "host_logger.h"

enum { MAX_FMUS = 8, MAX_ITEMS = 256, MAX_TEXT = 1024 };

typedef struct {
    char name[64];
    Library lib;
    fmi2Component c;
    fmi2InstantiateTYPE* instantiate;
    fmi2SetupExperimentTYPE* setup;
    fmi2EnterInitializationModeTYPE* enter;
    fmi2ExitInitializationModeTYPE* exit_;
    fmi2SetRealTYPE* set;
    fmi2GetRealTYPE* get;
    fmi2DoStepTYPE* step;
    fmi2TerminateTYPE* terminate;
    fmi2FreeInstanceTYPE* free_;
    /* what a master couples with; NULL where the FMU does not export them (then unused) */
    fmi2GetRealOutputDerivativesTYPE* output_derivatives;
    fmi2SetRealInputDerivativesTYPE* input_derivatives;
    fmi2GetDirectionalDerivativeTYPE* directional;
} Fmu;

typedef struct {
    int from, to;
    fmi2ValueReference from_vr, to_vr;
} Link;

typedef struct {
    int fmu;
    fmi2ValueReference vr;
    double value;
} Item;

static Fmu fmus[MAX_FMUS];
static int n_fmus;
static Link links[MAX_ITEMS];
static int n_links;
static Item sets[MAX_ITEMS], records[MAX_ITEMS];
static int n_sets, n_records;
static Link directionals[MAX_ITEMS];     /* fmu (from = to), unknown (from_vr), known (to_vr) */
static int n_directionals;
static int extrapolate;
static int bad;


static int find(const char* name)
{
    for (int i = 0; i < n_fmus; i++)
        if (strcmp(fmus[i].name, name) == 0) return i;
    printf("plan: no fmu named %s\n", name);
    exit(2);
}

static void check(fmi2Status s, const char* call, const Fmu* f)
{
    if (s != fmi2OK) {
        printf("status %s %s %d\n", call, f->name, (int)s);
        bad = 1;
    }
}

#define LOAD(field, type, exported)                                      \
    f->field = (type*)symbol(f->lib, exported);                          \
    if (!f->field) {                                                     \
        printf("%s: missing symbol %s\n", f->name, exported);            \
        exit(2);                                                         \
    }

static void load(Fmu* f, const char* dir, const char* model, const char* guid, fmi2CallbackFunctions* cb)
{
    char path[3 * MAX_TEXT], uri[3 * MAX_TEXT];
    snprintf(path, sizeof path, "%s/binaries/%s/%s%s", dir, BINARIES, model, SUFFIX);
    f->lib = open_library(path);
    if (!f->lib) {
        printf("%s: cannot load %s\n", f->name, path);
        exit(2);
    }
    LOAD(instantiate, fmi2InstantiateTYPE, "fmi2Instantiate")
    LOAD(setup, fmi2SetupExperimentTYPE, "fmi2SetupExperiment")
    LOAD(enter, fmi2EnterInitializationModeTYPE, "fmi2EnterInitializationMode")
    LOAD(exit_, fmi2ExitInitializationModeTYPE, "fmi2ExitInitializationMode")
    LOAD(set, fmi2SetRealTYPE, "fmi2SetReal")
    LOAD(get, fmi2GetRealTYPE, "fmi2GetReal")
    LOAD(step, fmi2DoStepTYPE, "fmi2DoStep")
    LOAD(terminate, fmi2TerminateTYPE, "fmi2Terminate")
    LOAD(free_, fmi2FreeInstanceTYPE, "fmi2FreeInstance")
    f->output_derivatives = (fmi2GetRealOutputDerivativesTYPE*)symbol(f->lib, "fmi2GetRealOutputDerivatives");
    f->input_derivatives = (fmi2SetRealInputDerivativesTYPE*)symbol(f->lib, "fmi2SetRealInputDerivatives");
    f->directional = (fmi2GetDirectionalDerivativeTYPE*)symbol(f->lib, "fmi2GetDirectionalDerivative");
    /* a file URI of the resources folder: file:///C:/... on Windows, file:///... elsewhere */
    snprintf(uri, sizeof uri, "file://%s%s/resources", dir[0] == '/' ? "" : "/", dir);
    for (char* p = uri; *p; p++)
        if (*p == '\\') *p = '/';
    f->c = f->instantiate(f->name, fmi2CoSimulation, guid, uri, cb, fmi2False, fmi2False);
    if (!f->c) {
        printf("%s: fmi2Instantiate returned NULL\n", f->name);
        exit(2);
    }
}

/* every connection's output read, then every input set; with slopes, each input also gets its
 * output's first derivative, read once every input is set (the derivative at the point the step
 * starts from) */
static void propagate(int slopes)
{
    double values[MAX_ITEMS], rates[MAX_ITEMS];
    const fmi2Integer first = 1;
    for (int k = 0; k < n_links; k++)
        check(fmus[links[k].from].get(fmus[links[k].from].c, &links[k].from_vr, 1, &values[k]), "fmi2GetReal",
              &fmus[links[k].from]);
    for (int k = 0; k < n_links; k++)
        check(fmus[links[k].to].set(fmus[links[k].to].c, &links[k].to_vr, 1, &values[k]), "fmi2SetReal",
              &fmus[links[k].to]);
    if (!slopes) return;
    for (int k = 0; k < n_links; k++) {
        const Fmu* f = &fmus[links[k].from];
        if (!f->output_derivatives) {
            printf("%s: no fmi2GetRealOutputDerivatives\n", f->name);
            exit(2);
        }
        check(f->output_derivatives(f->c, &links[k].from_vr, 1, &first, &rates[k]), "fmi2GetRealOutputDerivatives", f);
    }
    for (int k = 0; k < n_links; k++) {
        const Fmu* f = &fmus[links[k].to];
        if (!f->input_derivatives) {
            printf("%s: no fmi2SetRealInputDerivatives\n", f->name);
            exit(2);
        }
        check(f->input_derivatives(f->c, &links[k].to_vr, 1, &first, &rates[k]), "fmi2SetRealInputDerivatives", f);
    }
}

static void record(double t)
{
    printf("row %.17g", t);
    for (int k = 0; k < n_records; k++) {
        double value = 0.0;
        check(fmus[records[k].fmu].get(fmus[records[k].fmu].c, &records[k].vr, 1, &value), "fmi2GetReal",
              &fmus[records[k].fmu]);
        printf(",%.17g", value);
    }
    printf("\n");
}

int main(int argc, char** argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: %s PLAN\n", argv[0]);
        return 2;
    }
    FILE* plan = fopen(argv[1], "r");
    if (!plan) {
        printf("cannot open the plan %s\n", argv[1]);
        return 2;
    }
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    double h = 0.0, stop = 0.0;
    char line[4 * MAX_TEXT];
    while (fgets(line, sizeof line, plan)) {
        char a[MAX_TEXT], b[MAX_TEXT], c[MAX_TEXT], d[MAX_TEXT], e[MAX_TEXT];
        if (sscanf(line, "fmu %63s %1023s %1023s %1023s", a, b, c, d) == 4 && n_fmus < MAX_FMUS) {
            Fmu* f = &fmus[n_fmus++];
            strcpy(f->name, a);
            load(f, b, c, d, &cb);
        } else if (sscanf(line, "set %1023s %1023s %1023s", a, b, c) == 3 && n_sets < MAX_ITEMS) {
            sets[n_sets++] = (Item){find(a), (fmi2ValueReference)strtoul(b, NULL, 10), strtod(c, NULL)};
        } else if (sscanf(line, "connect %1023s %1023s %1023s %1023s", a, b, c, d) == 4 && n_links < MAX_ITEMS) {
            links[n_links++] = (Link){find(a), find(c), (fmi2ValueReference)strtoul(b, NULL, 10),
                                      (fmi2ValueReference)strtoul(d, NULL, 10)};
        } else if (sscanf(line, "record %1023s %1023s", a, b) == 2 && n_records < MAX_ITEMS) {
            records[n_records++] = (Item){find(a), (fmi2ValueReference)strtoul(b, NULL, 10), 0.0};
        } else if (sscanf(line, "directional %1023s %1023s %1023s", a, b, c) == 3 && n_directionals < MAX_ITEMS) {
            int i = find(a);
            directionals[n_directionals++] = (Link){i, i, (fmi2ValueReference)strtoul(b, NULL, 10),
                                                    (fmi2ValueReference)strtoul(c, NULL, 10)};
        } else if (strncmp(line, "extrapolate", 11) == 0) {
            extrapolate = 1;
        } else if (sscanf(line, "step %1023s", a) == 1) {
            h = strtod(a, NULL);
        } else if (sscanf(line, "stop %1023s", a) == 1) {
            stop = strtod(a, NULL);
        } else if (sscanf(line, "%1023s", e) == 1 && e[0] != '#') {
            printf("plan: cannot read the line %s", line);
            return 2;
        }
    }
    fclose(plan);
    if (!(h > 0.0 && stop > 0.0) || n_fmus == 0) {
        printf("plan: needs fmu lines, step > 0 and stop > 0\n");
        return 2;
    }
    printf("columns t");
    for (int k = 0; k < n_records; k++) printf(",%s.%u", fmus[records[k].fmu].name, (unsigned)records[k].vr);
    printf("\n");
    for (int i = 0; i < n_fmus; i++) {
        check(fmus[i].setup(fmus[i].c, fmi2False, 0.0, 0.0, fmi2True, stop), "fmi2SetupExperiment", &fmus[i]);
        check(fmus[i].enter(fmus[i].c), "fmi2EnterInitializationMode", &fmus[i]);
    }
    for (int k = 0; k < n_sets; k++)
        check(fmus[sets[k].fmu].set(fmus[sets[k].fmu].c, &sets[k].vr, 1, &sets[k].value), "fmi2SetReal",
              &fmus[sets[k].fmu]);
    propagate(0);
    propagate(0);
    for (int i = 0; i < n_fmus; i++) check(fmus[i].exit_(fmus[i].c), "fmi2ExitInitializationMode", &fmus[i]);
    long steps = (long)(stop / h + 0.5);
    record(0.0);
    for (long k = 0; k < steps && !bad; k++) {
        double t = k * h;
        propagate(extrapolate);
        for (int i = 0; i < n_fmus; i++) check(fmus[i].step(fmus[i].c, t, h, fmi2True), "fmi2DoStep", &fmus[i]);
        record((k + 1) * h);
    }
    for (int k = 0; k < n_directionals && !bad; k++) {
        const Link* d = &directionals[k];
        const Fmu* f = &fmus[d->from];
        double seed = 1.0, value = 0.0;
        if (!f->directional) {
            printf("%s: no fmi2GetDirectionalDerivative\n", f->name);
            exit(2);
        }
        check(f->directional(f->c, &d->from_vr, 1, &d->to_vr, 1, &seed, &value), "fmi2GetDirectionalDerivative", f);
        printf("directional %s %u %u %.17g\n", f->name, (unsigned)d->from_vr, (unsigned)d->to_vr, value);
    }
    for (int i = 0; i < n_fmus; i++) {
        fmus[i].terminate(fmus[i].c);
        fmus[i].free_(fmus[i].c);
    }
    return bad ? 1 : 0;
}
