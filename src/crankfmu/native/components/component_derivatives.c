/* A native component FMU's derivatives for masters (component_model.h's co_jacobian and
 * co_output_derivatives), on its equations at the current point (fmu_derivatives.h): z = (the
 * model's continuous states, then its inputs in value-reference order). The drives' states are
 * the armature current i, the speed error's integral x and, carrying the rotor, omega (i and omega
 * are outputs, so a master can name them); their rates are the circuit's and the rotor's equations
 * (cc_drive_rates), the outputs model_outputs. The cushion has no state: its force is a law of its
 * inputs. The rod string refuses: its grid's explicit steps are no smooth equations. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "component_model.h"
#include "fmu_derivatives.h"

enum { MAX_STATES = 3, MAX_Z = 16 };

typedef struct {
    const Component* c;
    double values[CM_MAX_VARIABLES];    /* at a trial z */
    double state[MAX_STATES + 1];
    const unsigned* unknowns;
    size_t n_unknowns;
    int n_states, n_inputs;
    int input_vr[MAX_Z];
    double z[MAX_Z], scale[MAX_Z], rates[MAX_Z];
} Point;

static int evaluate(void* model, const double* z, double* values, double* rates)
{
    Point* p = (Point*)model;
    const Component* c = p->c;
    memcpy(p->values, c->now.values, sizeof(double) * (size_t)c->d->n_variables);
    memcpy(p->state, c->now.state, sizeof(double) * (size_t)(p->n_states > 0 ? p->n_states : 0));
    for (int j = 0; j < p->n_states; j++) p->state[j] = z[j];
    for (int k = 0; k < p->n_inputs; k++) p->values[p->input_vr[k]] = z[p->n_states + k];
    model_outputs(c, p->values, p->state);
    if (rates) model_rates(c, p->values, p->state, rates);
    for (size_t i = 0; i < p->n_unknowns; i++) {
        double x = p->values[p->unknowns[i]];
        if (!isfinite(x)) return -1;
        if (values) values[i] = x;
    }
    return 0;
}

static int point_of(Component* c, const char* call, Point* p)
{
    p->c = c;
    if (c->now.phase != CM_STEPPING)
        return co_fail(c, "%s: allowed after the end of initialisation only (and before terminating)", call);
    p->n_states = model_smooth_states(c);
    if (p->n_states < 0)
        return co_fail(c, "%s: not provided by this FMU (a rod string's explicit steps on its grid are not smooth "
                       "equations a derivative can be taken of)", call);
    p->n_inputs = 0;
    for (int vr = 0; vr < c->d->n_variables; vr++)
        if (c->d->variables[vr].kind == KIND_INPUT && p->n_states + p->n_inputs < MAX_Z) p->input_vr[p->n_inputs++] = vr;
    for (int j = 0; j < p->n_states; j++) p->z[j] = c->now.state[j];
    for (int k = 0; k < p->n_inputs; k++) p->z[p->n_states + k] = c->now.values[p->input_vr[k]];
    for (int j = 0; j < p->n_states + p->n_inputs; j++) p->scale[j] = fmax(1.0, fabs(p->z[j]));
    return CM_OK;
}

static FdModel fd_model(Point* p, const unsigned* unknowns, size_t n)
{
    p->unknowns = unknowns;
    p->n_unknowns = n;
    FdModel f = {p, p->n_states, p->n_states + p->n_inputs, p->z, p->scale, n, evaluate};
    return f;
}

static int check_outputs(Component* c, const char* call, const unsigned* vr, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= (unsigned)c->d->n_variables) return co_fail(c, "%s: no variable has value reference %u", call, vr[i]);
        if (c->d->variables[vr[i]].kind != KIND_OUTPUT)
            return co_fail(c, "%s: %s is not an output", call, c->d->variables[vr[i]].name);
    }
    return CM_OK;
}

/* z's index of a known: an input, or an output that is one of the states; -1 otherwise */
static int known_index(const Component* c, const Point* p, unsigned vr)
{
    for (int k = 0; k < p->n_inputs; k++)
        if ((int)vr == p->input_vr[k]) return p->n_states + k;
    for (int j = 0; j < p->n_states; j++) {
        const char* name = model_state_output(c, j);
        if (name && vr < (unsigned)c->d->n_variables && strcmp(c->d->variables[vr].name, name) == 0) return j;
    }
    return -1;
}

int co_jacobian(Component* c, const char* call, const unsigned* unknowns, size_t n_unknowns, const unsigned* knowns,
                size_t n_knowns, double* jacobian)
{
    Point* p = (Point*)malloc(sizeof(Point));
    if (!p) return co_fail(c, "%s: out of memory", call);
    int status = point_of(c, call, p);
    if (status == CM_OK) status = check_outputs(c, call, unknowns, n_unknowns);
    int* columns = (int*)malloc(sizeof(int) * (n_knowns + 1));
    if (!columns && status == CM_OK) status = co_fail(c, "%s: out of memory", call);
    for (size_t k = 0; k < n_knowns && status == CM_OK; k++) {
        columns[k] = known_index(c, p, knowns[k]);
        if (columns[k] < 0)
            status = co_fail(c, "%s: value reference %u (%s) is neither an input nor an output that is a state: the "
                             "derivatives are with respect to those", call, knowns[k],
                             knowns[k] < (unsigned)c->d->n_variables ? c->d->variables[knowns[k]].name : "no variable");
    }
    if (status == CM_OK) {
        FdModel f = fd_model(p, unknowns, n_unknowns);
        if (fd_jacobian(&f, columns, (int)n_knowns, jacobian) != 0)
            status = co_fail(c, "%s: the model gives non-finite values near the current point", call);
    }
    free(columns);
    free(p);
    return status;
}

int co_output_derivatives(Component* c, const char* call, const unsigned* vr, size_t n, double* first,
                          double* second)
{
    Point* p = (Point*)malloc(sizeof(Point));
    if (!p) return co_fail(c, "%s: out of memory", call);
    int status = point_of(c, call, p);
    if (status == CM_OK) status = check_outputs(c, call, vr, n);
    if (status == CM_OK) {
        double rates[MAX_Z];
        for (int k = 0; k < p->n_inputs; k++) rates[k] = c->now.rate[p->input_vr[k]];
        FdModel f = fd_model(p, vr, n);
        if (fd_time_derivatives(&f, rates, first, second) != 0)
            status = co_fail(c, "%s: the model gives non-finite values near the current point", call);
    }
    free(p);
    return status;
}
