/* The FMU's linux64 binary: a thin shim in front of pythonfmu's binary.
 *
 * Why: pythonfmu's binary expects the host process to provide libpython, so a plain C or C++
 * host fails to load it (undefined symbol _Py_NoneStruct), and numpy's C extensions need
 * libpython in the *global* symbol scope, which dlopen(RTLD_LOCAL) hosts never give. On the
 * first fmi2Instantiate this shim loads libpython with RTLD_GLOBAL (unless the host already has
 * it, e.g. a Python host), from a Python it finds on the machine (find_python.c: the order is
 * documented there and in README), then loads pythonfmu's binary (<model>_pythonfmu.so beside
 * this file, <model> this file's own name: one shim, compiled when crankfmu is installed, serves
 * every Python FMU) and forwards every call.
 *
 * Where it brings Python in, the shim also starts the interpreter itself, so pythonfmu never
 * owns it and never runs Py_Finalize: finalising an interpreter that has loaded numpy and scipy
 * (and their BLAS threads) corrupted the heap at exit in about one run in ten here. The process
 * exit reclaims it instead, as usual for embedded Python with extension modules.
 *
 * It also fixes the status of refused input: pythonfmu maps any Python exception to fmi2Fatal
 * and returns fmi2OK from fmi2SetReal, so the slave logs its refusals with fmi2Error status
 * instead of raising. The shim wraps the host's logger, remembers the worst status logged
 * during a call, and returns fmi2Error from a call during which the slave logged an error.
 * pythonfmu drops every message while the host's loggingOn is false, so the inner instance is
 * always created with logging on and the shim applies the host's setting itself: warnings and
 * errors always reach the host (FMI 2.0 allows it: they are not debug messages), other
 * messages only while the host asked for them, in the categories it asked for.
 *
 * What the shim checks itself, before Python sees the call: fmi2DoStep's arguments (a finite
 * current time, a finite positive step), and calls on an instance that pythonfmu lost to a
 * fatal error (pythonfmu has already released its Python objects then: forwarding another call,
 * fmi2FreeInstance included, would use them after free). fmi2Discard from fmi2DoStep is made
 * fmi2Error: the model never asks a master to retry a smaller step, it refuses.
 *
 * And it gives each thread that calls it a Python thread state for good (keep_thread_state): a
 * master's worker thread (ecos steps its FMUs in a TBB pool) has none, and pythonfmu's per-call
 * PyGILState_Ensure and Release would create and destroy one on every call.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <link.h>
#include <math.h>
#include <unistd.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "find_python.h"

#define MAX_CATEGORIES 16

/* the live FMU states an instance remembers (a host holds one or a few; beyond this many a state
 * is simply not remembered, see fmi2FreeFMUstate) */
#define MAX_STATES 64

typedef struct {
    fmi2Component inner;
    fmi2CallbackFunctions host;     /* the host's callbacks */
    fmi2CallbackFunctions mine;     /* what the inner FMU gets: our logger, the host's memory */
    fmi2Status worst;               /* worst status logged during the current call */
    int host_logging;               /* the host's loggingOn / fmi2SetDebugLogging */
    size_t n_categories;            /* 0: every category */
    char categories[MAX_CATEGORIES][64];
    int lost;                       /* pythonfmu returned fmi2Fatal: never forward again */
    char name[256];
    void* states[MAX_STATES];       /* the FMU states pythonfmu handed out and not yet freed */
    size_t n_states;
} Shim;

static void* inner_lib = NULL;
static void (*inner_finalize)(void) = NULL;

/* pythonfmu takes the GIL per call with PyGILState_Ensure and gives it back with
 * PyGILState_Release. From a thread with no Python thread state that pair creates one and
 * destroys it again, its frame stack mapped and unmapped with it: three mmap and munmap pairs,
 * their page faults and a third of a step's time per step in ecos, whose TBB workers are such
 * threads. The first call from such a thread takes a thread state (PyGILState_Ensure) and gives
 * back only the GIL (PyEval_SaveThread): pythonfmu's pairs then find it and keep it. A thread
 * that has one already (a Python host's, or where the shim started the interpreter) is left as
 * it is. One thread state per calling thread stays until the process ends. */
static int (*python_gil_ensure)(void) = NULL;
static void* (*python_this_thread_state)(void) = NULL;
static void* (*python_save_thread)(void) = NULL;
static __thread int thread_state_kept = 0;

static void keep_thread_state(void)
{
    if (thread_state_kept) return;
    thread_state_kept = 1;
    if (!python_gil_ensure || !python_this_thread_state || !python_save_thread) return;
    if (python_this_thread_state()) return;
    python_gil_ensure();
    python_save_thread();
}

/* Other copies of pythonfmu's binary loaded before ours (another FMU's, e.g. a stock pythonfmu
 * FMU): they have the same use-after-free at exit, and the first copy loaded in a process owns
 * libstdc++'s STB_GNU_UNIQUE symbols, so it is never unloaded (dlclose is a no-op for it) and
 * its library destructor always runs at exit, after its static destructor. Once that freed
 * 128-byte block sits in a malloc bin, the destructor's decrement corrupts the bin's list and a
 * later free (libgfortran's destructor, from scipy) aborts with `corrupted double-linked list`.
 * Their statics were registered before our handler, so our handler runs before them and can
 * empty their pointer too. Copies loaded after our handler are left alone: their statics are
 * already destroyed when it runs. */
#define MAX_OTHERS 32
static void (*other_finalize[MAX_OTHERS])(void);
static size_t n_others = 0;

typedef struct {
    size_t n, capacity;
    char** name;
} LoadedNames;

static int collect_name(struct dl_phdr_info* info, size_t size, void* data)
{
    (void)size;
    LoadedNames* loaded = (LoadedNames*)data;
    if (!info->dlpi_name || !info->dlpi_name[0]) return 0;
    if (loaded->n == loaded->capacity) {
        size_t capacity = loaded->capacity ? 2 * loaded->capacity : 256;
        char** grown = (char**)realloc(loaded->name, capacity * sizeof *grown);
        if (!grown) return 1;
        loaded->name = grown;
        loaded->capacity = capacity;
    }
    if ((loaded->name[loaded->n] = strdup(info->dlpi_name))) loaded->n++;
    return 0;
}

/* the pythonfmu binaries loaded now, ours excepted: keep them loaded, remember their finaliser */
static void find_other_pythonfmu(void)
{
    LoadedNames loaded = {0, 0, NULL};
    dl_iterate_phdr(collect_name, &loaded);     /* names first: no dlopen inside its callback */
    for (size_t i = 0; i < loaded.n; i++) {
        void* h = n_others < MAX_OTHERS ? dlopen(loaded.name[i], RTLD_NOW | RTLD_NOLOAD) : NULL;
        void (*f)(void) = h ? (void (*)(void))dlsym(h, "finalizePythonInterpreter") : NULL;
        Dl_info where;
        /* a library that defines it itself (dlsym also searches its dependencies), not ours */
        if (f && f != inner_finalize && dladdr((void*)f, &where) && where.dli_fname &&
            strcmp(where.dli_fname, loaded.name[i]) == 0) {
            /* the handle is never closed: the library stays loaded, the pointer valid until exit */
            dlopen(loaded.name[i], RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
            other_finalize[n_others++] = f;
        } else if (h) {
            dlclose(h);
        }
        free(loaded.name[i]);
    }
    free(loaded.name);
}

/* pythonfmu keeps its interpreter state in a namespace-scope std::shared_ptr and also resets it
 * from a library destructor (finalizePythonInterpreter). At exit the C++ static destructor runs
 * first, then the library destructor assigns to the destroyed shared_ptr: a use-after-free
 * (seen with valgrind). This handler, registered after pythonfmu's statics, runs before them and
 * empties the pointer while everything is alive, so both later steps find nothing to release. */
static void release_python_at_exit(void)
{
    if (inner_finalize) inner_finalize();
    for (size_t i = 0; i < n_others; i++) other_finalize[i]();
}

/* the host's category filter for messages below fmi2Warning */
static int host_wants(const Shim* s, fmi2Status status, const char* category)
{
    if (status >= fmi2Warning) return 1;
    if (!s->host_logging) return 0;
    if (s->n_categories == 0) return 1;
    for (size_t i = 0; i < s->n_categories; i++)
        if (category && strcmp(category, s->categories[i]) == 0) return 1;
    return 0;
}

static const char* status_category(fmi2Status status)
{
    switch (status) {
    case fmi2Warning: return "logStatusWarning";
    case fmi2Discard: return "logStatusDiscard";
    case fmi2Error: return "logStatusError";
    case fmi2Fatal: return "logStatusFatal";
    default: return "logAll";
    }
}

/* every FMI 2.0 function forwarded to pythonfmu's binary: one list for declaring and binding */
#define FMI2_FORWARDED(X)                                                                            \
    X(fmi2SetDebugLogging) X(fmi2Instantiate) X(fmi2FreeInstance) X(fmi2SetupExperiment)             \
    X(fmi2EnterInitializationMode) X(fmi2ExitInitializationMode) X(fmi2Terminate) X(fmi2Reset)       \
    X(fmi2GetReal) X(fmi2GetInteger) X(fmi2GetBoolean) X(fmi2GetString)                              \
    X(fmi2SetReal) X(fmi2SetInteger) X(fmi2SetBoolean) X(fmi2SetString)                              \
    X(fmi2GetFMUstate) X(fmi2SetFMUstate) X(fmi2FreeFMUstate) X(fmi2SerializedFMUstateSize)          \
    X(fmi2SerializeFMUstate) X(fmi2DeSerializeFMUstate) X(fmi2GetDirectionalDerivative)              \
    X(fmi2SetRealInputDerivatives) X(fmi2GetRealOutputDerivatives) X(fmi2DoStep) X(fmi2CancelStep)   \
    X(fmi2GetStatus) X(fmi2GetRealStatus) X(fmi2GetIntegerStatus) X(fmi2GetBooleanStatus)           \
    X(fmi2GetStringStatus)

#define INNER(f) static f##TYPE* inner_##f = NULL;
FMI2_FORWARDED(INNER)

/* FMI hosts treat a log message as a printf format: double every '%' of plain text */
static void escape_percent(const char* text, char* out, size_t n)
{
    size_t j = 0;
    for (size_t i = 0; text[i] && j + 2 < n; i++) {
        if (text[i] == '%') out[j++] = '%';
        out[j++] = text[i];
    }
    out[j] = '\0';
}

static void shim_logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                        fmi2String category, fmi2String message, ...)
{
    Shim* s = (Shim*)env;
    char buffer[8192], escaped[16384];
    /* pythonfmu passes the text itself, with no arguments (Fmi2Logger::debugLog), not a format: read
       as a format, a '%' in the text (a description's "10 % slip") made vsnprintf read arguments that
       are not there and crash the host */
    snprintf(buffer, sizeof buffer, "%s", message ? message : "");
    if (status > s->worst) s->worst = status;
    /* pythonfmu's own messages (a Python exception) come without a category */
    if (!category || !category[0]) category = status_category(status);
    if (!host_wants(s, status, category)) return;
    /* pass the text itself as the message: hosts written with ctypes cannot read varargs */
    escape_percent(buffer, escaped, sizeof escaped);
    if (s->host.logger) s->host.logger(s->host.componentEnvironment, name, status, category, escaped);
}

/* an error the shim finds itself: always logged, whatever the host's logging setting */
static fmi2Status shim_error(Shim* s, const char* format, ...)
{
    char text[2048], escaped[4096];
    va_list ap;
    va_start(ap, format);
    vsnprintf(text, sizeof text, format, ap);
    va_end(ap);
    escape_percent(text, escaped, sizeof escaped);
    if (s->host.logger) s->host.logger(s->host.componentEnvironment, s->name, fmi2Error, "logStatusError", escaped);
    return fmi2Error;
}

static void host_log(const fmi2CallbackFunctions* cb, fmi2String name, const char* message, const char* detail)
{
    char text[16384], escaped[32768];
    snprintf(text, sizeof text, "%s%s", message, detail ? detail : "");
    escape_percent(text, escaped, sizeof escaped);
    if (cb && cb->logger) cb->logger(cb->componentEnvironment, name, fmi2Error, "logStatusError", escaped);
}

/* path of the resources directory from the file URI the host gives */
static void resources_path(const char* uri, char* out, size_t n)
{
    const char* p = uri ? uri : "";
    if (strncmp(p, "file://", 7) == 0) p += 7;
    else if (strncmp(p, "file:", 5) == 0) p += 5;
    if (strncmp(p, "localhost/", 10) == 0) p += 9;
    snprintf(out, n, "%s", p);
    size_t len = strlen(out);
    while (len > 1 && out[len - 1] == '/') out[--len] = '\0';
}

static int load(const char* resources, const fmi2CallbackFunctions* cb, fmi2String name)
{
    if (inner_lib) return 1;
    /* a Python host: use its interpreter */
    if (!dlsym(RTLD_DEFAULT, "Py_IsInitialized")) {
        static char message[12288];     /* static: large, and load runs once, under the host's first instantiation */
        if (!find_and_start_python(resources, message, sizeof message)) {
            host_log(cb, name, message, NULL);
            return 0;
        }
    }
    Dl_info info;
    char inner_path[4096];
    if (!dladdr((void*)&fmi2Instantiate, &info) || !info.dli_fname) {
        host_log(cb, name, "cannot locate the FMU binary", NULL);
        return 0;
    }
    /* <dir>/<model>.so -> <dir>/<model>_pythonfmu.so */
    snprintf(inner_path, sizeof inner_path, "%s", info.dli_fname);
    size_t length = strlen(inner_path);
    if (length > 3 && strcmp(inner_path + length - 3, ".so") == 0) inner_path[length - 3] = '\0';
    if (strlen(inner_path) + sizeof "_pythonfmu.so" > sizeof inner_path) {
        host_log(cb, name, "the FMU binary's path is too long: ", info.dli_fname);
        return 0;
    }
    strcat(inner_path, "_pythonfmu.so");
    void* lib = dlopen(inner_path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        host_log(cb, name, "cannot load pythonfmu's binary: ", dlerror());
        return 0;
    }
#define BIND(f)                                             \
    inner_##f = (f##TYPE*)dlsym(lib, #f);                   \
    if (!inner_##f) {                                       \
        host_log(cb, name, "missing symbol in pythonfmu's binary: ", #f); \
        return 0;                                           \
    }
    FMI2_FORWARDED(BIND)
    python_gil_ensure = (int (*)(void))dlsym(RTLD_DEFAULT, "PyGILState_Ensure");
    python_this_thread_state = (void* (*)(void))dlsym(RTLD_DEFAULT, "PyGILState_GetThisThreadState");
    python_save_thread = (void* (*)(void))dlsym(RTLD_DEFAULT, "PyEval_SaveThread");
    inner_lib = lib;
    /* In every host, Python or not: the use-after-free of pythonfmu's library destructor happens
     * at any process exit once an instance was created (valgrind shows it in an fmpy host too,
     * where it aborted about one process in two hundred with `corrupted double-linked list`).
     * In a Python host the interpreter is already finalised when this runs, and pythonfmu's
     * state then only joins its finished thread: no Python call is made. */
    inner_finalize = (void (*)(void))dlsym(lib, "finalizePythonInterpreter");
    if (inner_finalize) {
        /* stay loaded, so the handler below is not run (and then dangling) at a host's dlclose */
        dlopen(info.dli_fname, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
        find_other_pythonfmu();     /* before atexit: exactly the copies whose statics precede it */
        atexit(release_python_at_exit);
    }
    return 1;
}

/* an error logged during the call makes the call an error (never downgrade a worse status);
 * a fatal return means pythonfmu released the instance's Python objects: never call it again */
static fmi2Status merged(Shim* s, fmi2Status returned)
{
    if (returned == fmi2Fatal) s->lost = 1;
    if (s->worst >= fmi2Error && returned < fmi2Error) return fmi2Error;
    return returned;
}

#define SHIM(c)                                                                                    \
    Shim* s = (Shim*)(c);                                                                          \
    if (!s || !inner_lib) return fmi2Error;                                                        \
    if (s->lost) return shim_error(s, "this instance was lost to an earlier fatal error: free it"); \
    keep_thread_state();                                                                           \
    s->worst = fmi2OK
#define FORWARD(call) do { fmi2Status r_ = (call); return merged(s, r_); } while (0)

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resource_uri,
                              const fmi2CallbackFunctions* callbacks, fmi2Boolean visible, fmi2Boolean logging_on)
{
    char resources[4096];
    resources_path(resource_uri, resources, sizeof resources);
    if (!load(resources, callbacks, name)) return NULL;
    keep_thread_state();
    Shim* s = (Shim*)calloc(1, sizeof(Shim));
    if (!s) return NULL;
    if (callbacks) s->host = *callbacks;
    snprintf(s->name, sizeof s->name, "%s", name ? name : "");
    s->host_logging = logging_on == fmi2True;
    if (type != fmi2CoSimulation) {
        shim_error(s, "fmi2Instantiate: this FMU is for co-simulation only (fmuType = fmi2CoSimulation)");
        free(s);
        return NULL;
    }
    s->mine = s->host;
    s->mine.logger = shim_logger;
    s->mine.componentEnvironment = s;
    /* pythonfmu logs only with loggingOn: keep it on and filter here (see the top of this file) */
    s->inner = inner_fmi2Instantiate(name, type, guid, resource_uri, &s->mine, visible, fmi2True);
    if (!s->inner) {
        shim_error(s, "fmi2Instantiate failed: the FMU's Python side could not start (see the message before)");
        free(s);
        return NULL;
    }
    return s;
}

void fmi2FreeInstance(fmi2Component c)
{
    Shim* s = (Shim*)c;
    if (!s) return;
    /* a lost instance is leaked, not freed: pythonfmu already released its Python objects */
    if (inner_lib && s->inner && !s->lost) inner_fmi2FreeInstance(s->inner);
    free(s);   /* pythonfmu's binary stays loaded: an embedded Python cannot be unloaded */
}

/* the host's setting is applied by shim_logger; the inner instance keeps logging everything */
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cats[])
{
    SHIM(c);
    if (n > MAX_CATEGORIES) return shim_error(s, "fmi2SetDebugLogging: at most %d categories", MAX_CATEGORIES);
    for (size_t i = 0; i < n; i++) {
        if (!cats || !cats[i]) return shim_error(s, "fmi2SetDebugLogging: category %zu is NULL", i);
        snprintf(s->categories[i], sizeof s->categories[i], "%s", cats[i]);
    }
    s->n_categories = n;
    s->host_logging = on == fmi2True;
    return fmi2OK;
}
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tol_defined, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stop_defined, fmi2Real stop)
{ SHIM(c); FORWARD(inner_fmi2SetupExperiment(s->inner, tol_defined, tol, start, stop_defined, stop)); }
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { SHIM(c); FORWARD(inner_fmi2EnterInitializationMode(s->inner)); }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { SHIM(c); FORWARD(inner_fmi2ExitInitializationMode(s->inner)); }
fmi2Status fmi2Terminate(fmi2Component c) { SHIM(c); FORWARD(inner_fmi2Terminate(s->inner)); }
fmi2Status fmi2Reset(fmi2Component c) { SHIM(c); FORWARD(inner_fmi2Reset(s->inner)); }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
{ SHIM(c); FORWARD(inner_fmi2GetReal(s->inner, vr, n, v)); }
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
{ SHIM(c); FORWARD(inner_fmi2GetInteger(s->inner, vr, n, v)); }
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
{ SHIM(c); FORWARD(inner_fmi2GetBoolean(s->inner, vr, n, v)); }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
{ SHIM(c); FORWARD(inner_fmi2GetString(s->inner, vr, n, v)); }
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[])
{ SHIM(c); FORWARD(inner_fmi2SetReal(s->inner, vr, n, v)); }
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[])
{ SHIM(c); FORWARD(inner_fmi2SetInteger(s->inner, vr, n, v)); }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[])
{ SHIM(c); FORWARD(inner_fmi2SetBoolean(s->inner, vr, n, v)); }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[])
{ SHIM(c); FORWARD(inner_fmi2SetString(s->inner, vr, n, v)); }

/* The states pythonfmu hands out are remembered (by address only, never read), so that a host that
 * passes fmi2FreeFMUstate the state itself instead of its address is understood, not crashed:
 * fmusim (modelica/Reference-FMUs 0.0.39) does, after --final-fmu-state-file and
 * --initial-fmu-state-file, and pythonfmu then reads the state's bytes as a pointer (SIGSEGV). */
static int state_index(const Shim* s, const void* state)
{
    for (size_t i = 0; state && i < s->n_states; i++)
        if (s->states[i] == state) return (int)i;
    return -1;
}

static void remember_state(Shim* s, void* state)
{
    if (state && state_index(s, state) < 0 && s->n_states < MAX_STATES) s->states[s->n_states++] = state;
}

static void forget_state(Shim* s, const void* state)
{
    int i = state_index(s, state);
    if (i >= 0) s->states[i] = s->states[--s->n_states];
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* state)
{
    SHIM(c);
    fmi2Status r = merged(s, inner_fmi2GetFMUstate(s->inner, state));
    if (r <= fmi2Warning && state) remember_state(s, *state);
    return r;
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) { SHIM(c); FORWARD(inner_fmi2SetFMUstate(s->inner, state)); }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* state)
{
    SHIM(c);
    if (state && state_index(s, (const void*)state) >= 0) {     /* given the state itself, not its address */
        fmi2FMUstate own = (fmi2FMUstate)state;
        forget_state(s, own);
        FORWARD(inner_fmi2FreeFMUstate(s->inner, &own));
    }
    if (state) forget_state(s, *state);
    FORWARD(inner_fmi2FreeFMUstate(s->inner, state));
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t* size)
{ SHIM(c); FORWARD(inner_fmi2SerializedFMUstateSize(s->inner, state, size)); }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size)
{ SHIM(c); FORWARD(inner_fmi2SerializeFMUstate(s->inner, state, bytes, size)); }
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate* state)
{
    SHIM(c);
    fmi2Status r = merged(s, inner_fmi2DeSerializeFMUstate(s->inner, bytes, size, state));
    if (r <= fmi2Warning && state) remember_state(s, *state);
    return r;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference unknown[], size_t nu,
                                        const fmi2ValueReference known[], size_t nk, const fmi2Real dv_known[],
                                        fmi2Real dv_unknown[])
{ SHIM(c); FORWARD(inner_fmi2GetDirectionalDerivative(s->inner, unknown, nu, known, nk, dv_known, dv_unknown)); }

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real v[])
{ SHIM(c); FORWARD(inner_fmi2SetRealInputDerivatives(s->inner, vr, n, order, v)); }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real v[])
{ SHIM(c); FORWARD(inner_fmi2GetRealOutputDerivatives(s->inner, vr, n, order, v)); }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_prior)
{
    SHIM(c);
    if (!isfinite(t)) return shim_error(s, "fmi2DoStep: currentCommunicationPoint = %g s must be finite", t);
    if (!(isfinite(h) && h > 0.0))
        return shim_error(s, "fmi2DoStep: communicationStepSize = %g s must be finite and > 0 (valid range (0, inf) s)", h);
    fmi2Status r = merged(s, inner_fmi2DoStep(s->inner, t, h, no_prior));
    if (r == fmi2Discard) {
        /* pythonfmu's answer to a step the model refused; the model logs why */
        if (s->worst < fmi2Error) shim_error(s, "fmi2DoStep: the step from t = %g s was refused", t);
        return fmi2Error;
    }
    return r;
}
fmi2Status fmi2CancelStep(fmi2Component c) { SHIM(c); FORWARD(inner_fmi2CancelStep(s->inner)); }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind k, fmi2Status* v) { SHIM(c); FORWARD(inner_fmi2GetStatus(s->inner, k, v)); }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real* v) { SHIM(c); FORWARD(inner_fmi2GetRealStatus(s->inner, k, v)); }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer* v) { SHIM(c); FORWARD(inner_fmi2GetIntegerStatus(s->inner, k, v)); }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k, fmi2Boolean* v) { SHIM(c); FORWARD(inner_fmi2GetBooleanStatus(s->inner, k, v)); }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String* v) { SHIM(c); FORWARD(inner_fmi2GetStringStatus(s->inner, k, v)); }
