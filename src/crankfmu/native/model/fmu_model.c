/* The one model API (fmu_model.h): the model file read, then each call sent to the model of its
 * kind, the mechanism's (crank_model.c) or a component's (component_model.c). */
#include "fmu_model.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int fm_fail(const FmuModel* f, const char* format, ...)
{
    va_list args;
    va_start(args, format);
    cm_refusal(f->log, f->host, format, args);
    va_end(args);
    return CM_ERROR;
}

int fm_set_logging(FmuModel* f, int on)
{
    f->logging_on = on;
    return CM_OK;
}

#define MECHANISM(f) ((f)->d->kind == CM_MODEL_MECHANISM)

int fm_init(FmuModel* f, const char* call, const char* resources, int is_uri, const char* guid, int model_exchange,
            CmLogger log, void* host)
{
    char why[1024];
    memset(f, 0, sizeof *f);
    f->log = log;
    f->host = host;
    ModelData* d = md_load(resources, is_uri, why, sizeof why);
    if (!d) return fm_fail(f, "%s: %s", call, why);
    f->d = d;
    int status;
    if (!guid || strcmp(guid, d->guid) != 0)
        status = fm_fail(f, "%s: the GUID (instantiation token) %s is not this FMU's (%s, in %s)", call,
                         guid ? guid : "(null)", d->guid, CM_MODEL_FILE);
    else if (model_exchange && !MECHANISM(f))
        status = fm_fail(f, "%s: %s.fmu is a Co-Simulation FMU: instantiate it for Co-Simulation", call, d->identifier);
    else if (model_exchange && d->causality_speed)
        status = fm_fail(f, "%s: this FMU is Co-Simulation only: in speed causality tau_drive needs omega1's "
                         "derivative, which a Model Exchange host cannot pass", call);
    else if (MECHANISM(f))
        status = cm_init(&f->mechanism, call, d, model_exchange, log, host);
    else
        status = co_init(&f->component, call, d, log, host);
    if (status != CM_OK) {
        md_free(d);                      /* (the model took nothing: it refused before, or freed it) */
        f->d = NULL;
        return CM_ERROR;
    }
    return CM_OK;
}

void fm_free(FmuModel* f)
{
    if (!f->d) return;
    if (MECHANISM(f)) cm_free(&f->mechanism);
    else co_free(&f->component);
    md_free((ModelData*)f->d);
    f->d = NULL;
}

const char* fm_event_mode_refusal(const FmuModel* f)
{
    /* the events are a torque-causal mechanism's switches */
    if (!MECHANISM(f)) return "it has no events";
    return f->d->causality_speed ? "in speed causality the host's omega1 drives it, no switch is located" : NULL;
}

int fm_is_model_exchange(const FmuModel* f) { return MECHANISM(f) && f->mechanism.model_exchange; }
size_t fm_n_indicators(const FmuModel* f) { return MECHANISM(f) ? CK_N_SLOTS : 0; }
size_t fm_n_states(const FmuModel* f) { return fm_is_model_exchange(f) ? (size_t)f->d->n_states : 0; }
double fm_time(const FmuModel* f) { return MECHANISM(f) ? f->mechanism.now.time : f->component.now.time; }
int fm_phase(const FmuModel* f) { return MECHANISM(f) ? f->mechanism.now.phase : f->component.now.phase; }

int fm_reset(FmuModel* f)
{
    if (MECHANISM(f)) cm_reset(&f->mechanism);
    else co_reset(&f->component);
    return CM_OK;
}

int fm_setup(FmuModel* f, const char* call, double start_time, int stop_defined, double stop_time)
{
    return MECHANISM(f) ? cm_setup(&f->mechanism, call, start_time, stop_defined, stop_time)
                        : co_setup(&f->component, call, start_time, stop_defined, stop_time);
}

int fm_enter_initialization(FmuModel* f, const char* call)
{
    return MECHANISM(f) ? cm_enter_initialization(&f->mechanism, call) : co_enter_initialization(&f->component, call);
}

int fm_exit_initialization(FmuModel* f, const char* call)
{
    return MECHANISM(f) ? cm_exit_initialization(&f->mechanism, call) : co_exit_initialization(&f->component, call);
}

int fm_terminate(FmuModel* f)
{
    if (MECHANISM(f)) cm_terminate(&f->mechanism);
    else f->component.now.phase = CM_TERMINATED;
    return CM_OK;
}

int fm_do_step(FmuModel* f, const char* call, double t, double h, int switches, double* t_end, int* stopped)
{
    if (MECHANISM(f)) return cm_do_step(&f->mechanism, call, t, h, switches, t_end, stopped);
    *stopped = 0;
    int status = co_do_step(&f->component, call, t, h);
    *t_end = f->component.now.time;
    return status;
}

int fm_get(FmuModel* f, const char* call, const unsigned* vr, size_t n, double* value)
{
    return MECHANISM(f) ? cm_get(&f->mechanism, call, vr, n, value) : co_get(&f->component, call, vr, n, value);
}

int fm_set(FmuModel* f, const char* call, const unsigned* vr, size_t n, const double* value)
{
    return MECHANISM(f) ? cm_set(&f->mechanism, call, vr, n, value) : co_set(&f->component, call, vr, n, value);
}

int fm_set_input_derivatives(FmuModel* f, const char* call, const unsigned* vr, size_t n, const int* order,
                             const double* value)
{
    if (MECHANISM(f)) return cm_set_input_derivatives(&f->mechanism, call, vr, n, order, value);
    return co_set_input_derivatives(&f->component, call, vr, n, order, value);
}

/* ------------------------------------------------------------------------------ for masters */

/* the model's equations at the current point (its point, to free), or NULL refused */
static void* point_of(FmuModel* f, const char* call, const unsigned* unknowns, size_t n, int trajectory, FdModel* fd)
{
    return MECHANISM(f) ? cm_point(&f->mechanism, call, unknowns, n, trajectory, fd)
                        : co_point(&f->component, call, unknowns, n, fd);
}

static int not_finite(FmuModel* f, const char* call)
{
    return fm_fail(f, "%s: the model gives non-finite values near the current point (t = %.9g s)", call, fm_time(f));
}

int fm_directional(FmuModel* f, const char* call, const unsigned* unknowns, size_t n_unknowns, const unsigned* knowns,
                   size_t n_knowns, const double* seed, double* sensitivity, int adjoint)
{
    if ((n_unknowns > 0 && (!unknowns || (adjoint ? !seed : !sensitivity))) ||
        (n_knowns > 0 && (!knowns || (adjoint ? !sensitivity : !seed))))
        return fm_fail(f, "%s: null arrays", call);
    if (n_unknowns > CM_MAX_VARIABLES || n_knowns > CM_MAX_VARIABLES)
        return fm_fail(f, "%s: %lu unknowns and %lu knowns: this FMU has at most %d variables", call,
                       (unsigned long)n_unknowns, (unsigned long)n_knowns, CM_MAX_VARIABLES);
    FdModel fd;
    void* point = point_of(f, call, unknowns, n_unknowns, 0, &fd);
    if (!point) return CM_ERROR;
    double* jacobian = (double*)malloc(sizeof(double) * (n_unknowns * n_knowns + 1));
    size_t refused = 0;
    int found = jacobian ? fd_jacobian(&fd, knowns, n_knowns, jacobian, &refused) : FD_NOT_FINITE;
    free(point);
    int status = CM_OK;
    if (!jacobian)
        status = fm_fail(f, "%s: out of memory", call);
    else if (found == FD_NOT_A_KNOWN)
        status = fm_fail(f, "%s: value reference %u (%s) is neither a continuous state nor an input of this FMU "
                         "(an output that is a state counts as one): the derivatives are with respect to those",
                         call, knowns[refused],
                         knowns[refused] < (unsigned)f->d->n_variables ? f->d->variables[knowns[refused]].name
                                                                        : "no variable");
    else if (found != FD_OK)
        status = not_finite(f, call);
    size_t n_out = adjoint ? n_knowns : n_unknowns;
    for (size_t r = 0; r < n_out && status == CM_OK; r++) {
        /* the Jacobian times the seed, or its transpose times the seed */
        double sum = 0.0;
        for (size_t q = 0; q < (adjoint ? n_unknowns : n_knowns); q++)
            sum += (adjoint ? jacobian[q * n_knowns + r] : jacobian[r * n_knowns + q]) * seed[q];
        sensitivity[r] = sum;
    }
    free(jacobian);
    return status;
}

int fm_output_derivatives(FmuModel* f, const char* call, const unsigned* vr, size_t n, const int* order, double* value)
{
    if (n > 0 && (!vr || !order || !value)) return fm_fail(f, "%s: null arrays", call);
    if (n > CM_MAX_VARIABLES)
        return fm_fail(f, "%s: %lu outputs: this FMU has at most %d variables", call, (unsigned long)n, CM_MAX_VARIABLES);
    for (size_t i = 0; i < n; i++)
        if (order[i] < 1 || order[i] > FM_MAX_OUTPUT_DERIVATIVE_ORDER)
            return fm_fail(f, "%s: order %d: this FMU gives the first and second derivatives (maxOutputDerivativeOrder "
                           "= %d)", call, order[i], FM_MAX_OUTPUT_DERIVATIVE_ORDER);
    FdModel fd;
    void* point = point_of(f, call, vr, n, 1, &fd);
    if (!point) return CM_ERROR;
    double* both = (double*)malloc(sizeof(double) * (2 * n + 1));
    int found = both ? fd_time_derivatives(&fd, both, both + n) : FD_NOT_FINITE;
    free(point);
    int status = !both ? fm_fail(f, "%s: out of memory", call) : found != FD_OK ? not_finite(f, call) : CM_OK;
    for (size_t i = 0; i < n && status == CM_OK; i++) value[i] = both[(order[i] - 1) * n + i];
    free(both);
    return status;
}

/* ------------------------------------------------------------------------------ Model Exchange */

int fm_me(FmuModel* f, const char* call, int operation, double* x, size_t n)
{
    if (!MECHANISM(f)) return fm_fail(f, "%s: this instance is Co-Simulation", call);
    Model* m = &f->mechanism;
    switch (operation) {
    case FM_ME_READY: return cm_me_ready(m, call, 0);
    case FM_ME_SET_TIME: return cm_me_set_time(m, call, x[0]);
    case FM_ME_SET_STATES: return cm_me_set_states(m, call, x, n);
    case FM_ME_GET_STATES: return cm_me_get_states(m, call, x, n);
    case FM_ME_GET_DERIVATIVES: return cm_me_get_derivatives(m, call, x, n);
    case FM_ME_GET_INDICATORS: return cm_me_get_indicators(m, call, x, n);
    default: return cm_me_get_nominals(m, call, x, n);
    }
}

int fm_me_update(FmuModel* f, const char* call, int* states_changed)
{
    if (!MECHANISM(f)) return fm_fail(f, "%s: this instance is Co-Simulation", call);
    return cm_me_update(&f->mechanism, call, states_changed);
}

/* ------------------------------------------------------------------------------ FMU states */

/* a copy of the instance's state into reuse (a state of this FMU's) or new memory; NULL where
 * memory lacks */
static void* copy_state(FmuModel* f, void* reuse)
{
    if (MECHANISM(f)) {
        Snapshot* s = (Snapshot*)(reuse ? reuse : malloc(sizeof(Snapshot)));
        if (s) *s = f->mechanism.now;
        return s;
    }
    CoSnapshot* s = (CoSnapshot*)(reuse ? reuse : calloc(1, sizeof(CoSnapshot)));
    if (s && co_copy(s, &f->component.now)) return s;
    if (s && !reuse) free(s);
    return NULL;
}

int fm_state_save(FmuModel* f, const char* call, void** state)
{
    if (!state) return fm_fail(f, "%s: no place for the state (null)", call);
    void* s = copy_state(f, fmu_state_is_ours(*state) ? *state : NULL);
    if (!s) return fm_fail(f, "%s: out of memory", call);
    *state = s;
    return CM_OK;
}

int fm_state_restore(FmuModel* f, const char* call, const void* state)
{
    if (!fmu_state_is_ours(state)) return fm_fail(f, "%s: no state of this FMU (null, or freed already)", call);
    if (MECHANISM(f)) {
        cm_restore(&f->mechanism, (const Snapshot*)state);
        return CM_OK;
    }
    Component* c = &f->component;
    if (!co_copy(&c->now, (const CoSnapshot*)state)) {
        co_reset(c);
        return fm_fail(f, "%s: out of memory (the instance is reset)", call);
    }
    c->stale = c->now.phase == CM_INITIALIZATION;
    return CM_OK;
}

int fm_state_release(FmuModel* f, const char* call, void** given)
{
    if (!given) return fm_fail(f, "%s: no state (null)", call);
    int slipped;                         /* the host passed the state, not its address (fmu_states.h) */
    void* s = fmu_state_to_free(given, &slipped);
    if (!s) return *given ? fm_fail(f, "%s: not a state of this FMU (freed already?): nothing freed", call) : CM_OK;
    if (!MECHANISM(f)) co_release((CoSnapshot*)s);
    fmu_state_unmark(s);
    free(s);
    if (!slipped) *given = NULL;
    return CM_OK;
}

static size_t bytes_of(const FmuModel* f, const void* state)
{
    return MECHANISM(f) ? cm_serialized_size() : co_serialized_size((const CoSnapshot*)state);
}

int fm_state_size(FmuModel* f, const char* call, const void* state, size_t* size)
{
    if (!fmu_state_is_ours(state) || !size) return fm_fail(f, "%s: no state of this FMU, or no place for its size", call);
    *size = bytes_of(f, state);
    return CM_OK;
}

int fm_state_write(FmuModel* f, const char* call, const void* state, unsigned char* bytes, size_t size)
{
    if (!fmu_state_is_ours(state) || !bytes || size < bytes_of(f, state))
        return fm_fail(f, "%s: no state of this FMU, or a buffer of %lu bytes where its %lu bytes go", call,
                       (unsigned long)size, fmu_state_is_ours(state) ? (unsigned long)bytes_of(f, state) : 0UL);
    if (MECHANISM(f)) cm_serialize(&f->mechanism, (const Snapshot*)state, bytes);
    else co_serialize((const CoSnapshot*)state, bytes);
    return CM_OK;
}

int fm_state_read(FmuModel* f, const char* call, const unsigned char* bytes, size_t size, void** state)
{
    if (!state) return fm_fail(f, "%s: no place for the state (null)", call);
    void* reuse = fmu_state_is_ours(*state) ? *state : NULL;
    void* s;
    if (MECHANISM(f)) {
        Snapshot read;
        if (cm_deserialize(&f->mechanism, call, bytes, size, &read) != CM_OK) return CM_ERROR;
        s = reuse ? reuse : malloc(sizeof(Snapshot));
        if (s) *(Snapshot*)s = read;
    } else {
        s = reuse ? reuse : calloc(1, sizeof(CoSnapshot));
        if (s && co_deserialize(&f->component, call, bytes, size, (CoSnapshot*)s) != CM_OK) {
            if (!reuse) {
                co_release((CoSnapshot*)s);
                free(s);
            }
            return CM_ERROR;
        }
    }
    if (!s) return fm_fail(f, "%s: out of memory", call);
    *state = s;
    return CM_OK;
}
