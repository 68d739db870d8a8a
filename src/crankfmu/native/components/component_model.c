/* A native component FMU's model (component_model.h). What a component adds is data, its model file
 * (written by `crankfmu fmu ... --native`): its kind and its variables with their starts, ranges
 * and descriptions, as its data file declares them, in the Python FMU's order. The instance state
 * is one struct and the model's state array (its size known at initialisation: a rod string's grid
 * follows its tapers). Nothing allocates after instantiation except the model's state at
 * initialisation and an FMU state. */
#include "component_model.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crank_numbers.h"

static const char* PHASE[] = {"instantiated", "initialization mode", "stepping", "terminated", "failed"};

int co_fail(const Component* c, const char* format, ...)
{
    va_list args;
    va_start(args, format);
    cm_refusal(c->log, c->host, format, args);
    va_end(args);
    return CM_ERROR;
}

void co_reset(Component* c)
{
    free(c->now.state);
    memset(&c->now, 0, sizeof c->now);
    fmu_state_mark(&c->now);             /* every copy of it an FMU state hands out carries it */
    for (int i = 0; i < c->d->n_variables; i++) c->now.values[i] = c->d->variables[i].start;
    c->now.time = c->d->default_start_time;
    c->now.phase = CM_INSTANTIATED;
    c->stale = 0;
}

int co_init(Component* c, const char* call, const ModelData* d, CmLogger log, void* host)
{
    char why[512];
    memset(c, 0, sizeof *c);
    c->d = d;
    c->log = log;
    c->host = host;
    if (model_bind(c, why, sizeof why) != 0) return co_fail(c, "%s: the model file %s: %s", call, CM_MODEL_FILE, why);
    for (int vr = 0; vr < d->n_variables; vr++)
        if (d->variables[vr].kind == KIND_INPUT) c->input_vr[c->n_inputs++] = vr;
    co_reset(c);
    return CM_OK;
}

void co_free(Component* c)
{
    free(c->now.state);
    c->now.state = NULL;
    c->now.n_state = 0;
}

static int out_of_order(Component* c, const char* call, int allowed)
{
    if (c->now.phase == allowed) return 0;
    co_fail(c, "%s is not allowed in %s (only in %s)", call, PHASE[c->now.phase], PHASE[allowed]);
    return 1;
}

int co_setup(Component* c, const char* call, double start_time, int stop_defined, double stop_time)
{
    if (out_of_order(c, call, CM_INSTANTIATED)) return CM_ERROR;
    if (!isfinite(start_time)) return co_fail(c, "startTime = %s must be a finite time in s", shortest(start_time).text);
    if (stop_defined && !(stop_time >= start_time))
        return co_fail(c, "stopTime = %s must be >= startTime = %s s", shortest(stop_time).text,
                       shortest(start_time).text);
    c->now.time = start_time;
    return CM_OK;
}

int co_enter_initialization(Component* c, const char* call)
{
    if (out_of_order(c, call, CM_INSTANTIATED)) return CM_ERROR;
    c->now.phase = CM_INITIALIZATION;
    c->stale = 1;
    return CM_OK;
}

/* the model started at the values now set, its outputs computed: 0, or -1 with the reason in why */
static int start_model(Component* c, char* why, int why_size)
{
    int size = model_state_size(c, c->now.values, why, why_size);
    if (size <= 0) return -1;
    if (size != c->now.n_state) {
        free(c->now.state);
        c->now.n_state = 0;
        c->now.state = (double*)calloc((size_t)size, sizeof(double));
        if (!c->now.state) {
            snprintf(why, (size_t)why_size, "no memory for the model's %d values", size);
            return -1;
        }
        c->now.n_state = size;
    } else {
        memset(c->now.state, 0, sizeof(double) * (size_t)size);
    }
    model_start(c, c->now.values, c->now.time, c->now.state);
    model_outputs(c, c->now.values, c->now.state);
    return 0;
}

static int first_refused(const Component* c)
{
    for (int i = 0; i < c->d->n_variables; i++)
        if (c->now.refused[i]) return i;
    return -1;
}

static int outputs_finite(const Component* c)
{
    for (int i = 0; i < c->d->n_variables; i++)
        if (c->d->variables[i].kind == KIND_OUTPUT && !isfinite(c->now.values[i])) return 0;
    return 1;
}

int co_exit_initialization(Component* c, const char* call)
{
    if (out_of_order(c, call, CM_INITIALIZATION)) return CM_ERROR;
    if (first_refused(c) >= 0) {
        char names[512] = "";
        size_t used = 0;
        for (int i = 0; i < c->d->n_variables; i++)
            if (c->now.refused[i] && used + strlen(c->d->variables[i].name) + 3 < sizeof names)
                used += (size_t)snprintf(names + used, sizeof names - used, "%s%s", used ? ", " : "", c->d->variables[i].name);
        c->now.phase = CM_FAILED;
        return co_fail(c, "cannot initialise: no valid value set for %s (each was refused with its valid range; set a "
                       "valid value, or reset)", names);
    }
    char why[1024] = "";
    if (start_model(c, why, (int)sizeof why) != 0) {
        c->now.phase = CM_FAILED;
        return co_fail(c, "cannot initialise: %s", why);
    }
    c->stale = 0;
    if (!outputs_finite(c)) {
        char judged[1024] = "";
        size_t used = 0;
        for (int i = 0; i < c->d->n_variables; i++)
            if (c->d->variables[i].kind == KIND_OUTPUT && used + 64 < sizeof judged)
                used += (size_t)snprintf(judged + used, sizeof judged - used, "%s%s = %g", used ? ", " : "",
                                         c->d->variables[i].name, c->now.values[i]);
        c->now.phase = CM_FAILED;
        return co_fail(c, "the initial state is not finite (%s): check the parameters", judged);
    }
    c->now.phase = CM_STEPPING;
    return CM_OK;
}

void co_terminate(Component* c) { c->now.phase = CM_TERMINATED; }

/* a host's communication point is the FMU's own time up to the host's rounding (fmi/python/core.py's
 * time_matches) */
static int time_matches(double t_host, double t_own, double step)
{
    return fabs(t_host - t_own) <= 1e-9 * fmax(1.0, fabs(t_own)) + 1e-6 * step;
}

int co_do_step(Component* c, const char* call, double t, double h)
{
    if (c->now.phase != CM_STEPPING) {
        int r = first_refused(c);
        return co_fail(c, "%s: cannot step: %s", call,
                       c->now.phase == CM_TERMINATED ? "the instance was terminated" :
                       c->now.phase == CM_FAILED ? (r >= 0 ? c->d->variables[r].name : "the model was refused (reset it)") :
                       "the model is not initialised (exit initialisation mode first)");
    }
    double target = t + h;
    if (!(h > 0.0 && isfinite(target)))
        return co_fail(c, "%s: currentCommunicationPoint = %s s must be finite and communicationStepSize = %s s finite "
                       "and > 0", call, shortest(t).text, shortest(h).text);
    if (!time_matches(t, c->now.time, h))
        return co_fail(c, "%s: currentCommunicationPoint = %s s is not this FMU's time %s s (a step was skipped or "
                       "repeated; roll back with the FMU state)", call, shortest(t).text, shortest(c->now.time).text);
    int r = first_refused(c);
    if (r >= 0)
        return co_fail(c, "%s: cannot step: %s has no valid value (valid range %s)", call, c->d->variables[r].name,
                       c->d->variables[r].range);
    double dt = target - c->now.time;
    model_step(c, c->now.values, c->now.rate, c->now.state, dt);
    /* an input given a derivative ran as a line over the step, and is at its end there: the outputs
     * that read it at once (the cushion's force, the shaft's damping torque, the drive's voltage) are
     * the end's, as a master reading them before it sets the inputs again (a rollback's residual)
     * takes them; the next step goes on along the line unless the host sets the input */
    for (int k = 0; k < c->n_inputs; k++) {
        int vr = c->input_vr[k];
        if (c->now.rate[vr] != 0.0) c->now.values[vr] += c->now.rate[vr] * dt;
    }
    model_outputs(c, c->now.values, c->now.state);
    if (!outputs_finite(c)) {
        c->now.phase = CM_FAILED;
        return co_fail(c, "step from t = %s s gave non-finite values: check the inputs and parameters", shortest(t).text);
    }
    c->now.time = target;
    return CM_OK;
}

static int bad_reference(Component* c, unsigned vr, const char* call)
{
    if (vr < (unsigned)c->d->n_variables) return 0;
    co_fail(c, "%s: unknown value reference %u: this FMU's Real variables are 0..%d", call, vr, c->d->n_variables - 1);
    return 1;
}

int co_get(Component* c, const char* call, const unsigned* vr, size_t n, double* value)
{
    if (n > 0 && (!vr || !value)) return co_fail(c, "%s: null arrays", call);
    /* outputs read in initialisation mode are those of the values set now: a master reads them
     * there (its initial values' fixed point) before the end of initialisation. A model that
     * cannot start leaves them as they were; the end of initialisation refuses it with the reason */
    if (c->now.phase == CM_INITIALIZATION && c->stale && first_refused(c) < 0) {
        char why[1024] = "";
        if (start_model(c, why, (int)sizeof why) == 0) c->stale = 0;
    }
    int status = CM_OK;
    for (size_t k = 0; k < n; k++) {
        if (bad_reference(c, vr[k], call)) {
            value[k] = NAN;
            status = CM_ERROR;
            continue;
        }
        value[k] = c->now.values[vr[k]];
    }
    return status;
}

static int in_range(const Variable* v, double x)
{
    if (!isfinite(x)) return 0;
    if (v->has_min && (x < v->min || (x == v->min && !v->min_inclusive))) return 0;
    if (v->has_max && (x > v->max || (x == v->max && !v->max_inclusive))) return 0;
    return 1;
}

int co_set(Component* c, const char* call, const unsigned* vr, size_t n, const double* value)
{
    if (n > 0 && (!vr || !value)) return co_fail(c, "%s: null arrays", call);
    int status = CM_OK;
    for (size_t k = 0; k < n; k++) {
        if (bad_reference(c, vr[k], call)) {
            status = CM_ERROR;
            continue;
        }
        const Variable* v = &c->d->variables[vr[k]];
        double x = value[k];
        if (v->kind == KIND_OUTPUT || v->kind == KIND_DERIVATIVE) {
            status = co_fail(c, "%s is %s of this FMU: it cannot be set", v->name,
                             v->kind == KIND_OUTPUT ? "an output" : "a state's derivative");
            continue;
        }
        if (v->kind == KIND_FIXED && (c->now.phase == CM_STEPPING || c->now.phase == CM_TERMINATED)) {
            status = co_fail(c, "%s is a fixed parameter: it can only be set before the end of initialisation (value "
                             "kept: %s; valid range %s)", v->name, shortest(c->now.values[vr[k]]).text, v->range);
            continue;
        }
        if (!in_range(v, x)) {
            c->now.refused[vr[k]] = 1;
            if (v->kind == KIND_INPUT)
                status = co_fail(c, "input %s = %s must be finite (valid range %s)", v->name, shortest(x).text,
                                 v->range);
            else
                status = co_fail(c, "%s", out_of_range(v->name, x, v->range, v->description).text);
            continue;
        }
        c->now.refused[vr[k]] = 0;
        c->now.values[vr[k]] = x;
        if (v->kind == KIND_INPUT) c->now.rate[vr[k]] = 0.0;     /* held, unless a derivative follows */
        if (c->now.phase == CM_INITIALIZATION) c->stale = 1;
    }
    /* stepping, an output that depends on an input at once (the drive's voltage and power, the
     * cushion's force) is read at the inputs just set, as a master solving a loop by setting and
     * reading expects (the Python FMU's the same); the state moves at the next step */
    if (c->now.phase == CM_STEPPING && c->now.n_state > 0) model_outputs(c, c->now.values, c->now.state);
    return status;
}

int co_set_input_derivatives(Component* c, const char* call, const unsigned* vr, size_t n, const int* order,
                             const double* value)
{
    if (n > 0 && (!vr || !order || !value)) return co_fail(c, "%s: null arrays", call);
    for (size_t k = 0; k < n; k++) {
        if (bad_reference(c, vr[k], call)) return CM_ERROR;
        const Variable* v = &c->d->variables[vr[k]];
        if (v->kind != KIND_INPUT) return co_fail(c, "%s: %s is not an input of this FMU", call, v->name);
        if (order[k] != 1)
            return co_fail(c, "%s: %s: order %d; this FMU takes the first derivative only", call, v->name, order[k]);
        if (!isfinite(value[k]))
            return co_fail(c, "%s: %s: the derivative %s must be finite", call, v->name, shortest(value[k]).text);
    }
    for (size_t k = 0; k < n; k++) c->now.rate[vr[k]] = value[k];
    return CM_OK;
}

/* ---------------------------------------------------------------------------- FMU state */
static const char STATE_TAG[16] = "crankfmu-comp-04";

int co_copy(CoSnapshot* to, const CoSnapshot* from)
{
    double* state = to->state;
    if (to->n_state != from->n_state) {
        free(state);
        state = from->n_state ? (double*)malloc((size_t)from->n_state * sizeof(double)) : NULL;
        if (from->n_state && !state) {
            to->state = NULL;
            to->n_state = 0;
            return 0;
        }
    }
    *to = *from;
    to->state = state;
    if (from->n_state) memcpy(state, from->state, (size_t)from->n_state * sizeof(double));
    return 1;
}

void co_release(CoSnapshot* s)
{
    free(s->state);
    s->state = NULL;
    s->n_state = 0;
}

size_t co_serialized_size(const CoSnapshot* s)
{
    return sizeof STATE_TAG + sizeof(CoSnapshot) + (size_t)s->n_state * sizeof(double);
}

void co_serialize(const CoSnapshot* s, unsigned char* bytes)
{
    CoSnapshot head = *s;
    head.state = NULL;
    memcpy(bytes, STATE_TAG, sizeof STATE_TAG);
    memcpy(bytes + sizeof STATE_TAG, &head, sizeof head);
    if (s->n_state) memcpy(bytes + sizeof STATE_TAG + sizeof head, s->state, (size_t)s->n_state * sizeof(double));
}

int co_deserialize(const Component* c, const char* call, const unsigned char* bytes, size_t size, CoSnapshot* to)
{
    CoSnapshot head;
    /* each refusal says what it judged: the size, the tag, the phase and the state's length */
    if (!bytes || size < sizeof STATE_TAG + sizeof head)
        return co_fail(c, "%s: these %lu bytes are not a state of this FMU: its states are at least %lu bytes", call,
                       (unsigned long)size, (unsigned long)(sizeof STATE_TAG + sizeof head));
    if (memcmp(bytes, STATE_TAG, sizeof STATE_TAG) != 0)
        return co_fail(c, "%s: these %lu bytes are not a state of this FMU: they do not start with its states' tag "
                       "(another FMU's or another build's state?)", call, (unsigned long)size);
    memcpy(&head, bytes + sizeof STATE_TAG, sizeof head);
    head.state = NULL;
    if (head.phase < CM_INSTANTIATED || head.phase > CM_FAILED || head.n_state < 0 || size != co_serialized_size(&head))
        return co_fail(c, "%s: these %lu bytes are not a state of this FMU: phase %d (valid %d to %d), %d state values "
                       "(%lu bytes with them)", call, (unsigned long)size, (int)head.phase, (int)CM_INSTANTIATED,
                       (int)CM_FAILED, (int)head.n_state,
                       head.n_state >= 0 ? (unsigned long)co_serialized_size(&head) : 0UL);
    double* keep = to->state;
    if (to->n_state != head.n_state) {
        free(keep);
        keep = head.n_state ? (double*)malloc((size_t)head.n_state * sizeof(double)) : NULL;
        if (head.n_state && !keep) {
            to->state = NULL;
            to->n_state = 0;
            return co_fail(c, "%s: out of memory", call);
        }
    }
    *to = head;
    to->state = keep;
    if (head.n_state) memcpy(keep, bytes + sizeof STATE_TAG + sizeof head, (size_t)head.n_state * sizeof(double));
    return CM_OK;
}
