/* A native component FMU's equations for masters (component_model.h's co_point), on its equations at the current point (fmu_derivatives.h): z = (the
 * model's continuous states, then its inputs in value-reference order). The drives' states are
 * the armature current i, the speed error's integral x and, carrying the rotor, omega (outputs all,
 * so a master can name them as knowns); their rates der(i), der(x), der(omega) are the circuit's
 * and the rotor's equations (cc_drive_rates), written with the outputs by model_outputs. The cushion has no state: its force is a law of its
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
    model_outputs_rates(c, p->values, p->state, rates);   /* the rates once, with the outputs */
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
    for (int k = 0; k < c->n_inputs && p->n_states + p->n_inputs < MAX_Z; k++) p->input_vr[p->n_inputs++] = c->input_vr[k];
    for (int j = 0; j < p->n_states; j++) p->z[j] = c->now.state[j];
    for (int k = 0; k < p->n_inputs; k++) p->z[p->n_states + k] = c->now.values[p->input_vr[k]];
    for (int j = 0; j < p->n_states + p->n_inputs; j++) p->scale[j] = fmax(1.0, fabs(p->z[j]));
    return CM_OK;
}

/* z's index of a known: an input, or an output that is one of the states; -1 otherwise */
static int known_index(void* point, unsigned vr)
{
    const Point* p = (const Point*)point;
    const Component* c = p->c;
    for (int k = 0; k < p->n_inputs; k++)
        if ((int)vr == p->input_vr[k]) return p->n_states + k;
    for (int j = 0; j < p->n_states; j++) {
        const char* name = model_state_output(c, j);
        if (name && vr < (unsigned)c->d->n_variables && strcmp(c->d->variables[vr].name, name) == 0) return j;
    }
    return -1;
}

void* co_point(Component* c, const char* call, const unsigned* unknowns, size_t n_unknowns, FdModel* f)
{
    for (size_t i = 0; i < n_unknowns; i++) {
        if (unknowns[i] >= (unsigned)c->d->n_variables) {
            co_fail(c, "%s: no variable has value reference %u", call, unknowns[i]);
            return NULL;
        }
        int kind = c->d->variables[unknowns[i]].kind;
        if (kind != KIND_OUTPUT && kind != KIND_DERIVATIVE) {
            co_fail(c, "%s: %s is neither an output nor a state's derivative", call, c->d->variables[unknowns[i]].name);
            return NULL;
        }
    }
    Point* p = (Point*)malloc(sizeof(Point));
    if (!p) {
        co_fail(c, "%s: out of memory", call);
        return NULL;
    }
    if (point_of(c, call, p) != CM_OK) {
        free(p);
        return NULL;
    }
    p->unknowns = unknowns;
    p->n_unknowns = n_unknowns;
    for (int k = 0; k < p->n_inputs; k++) p->rates[k] = c->now.rate[p->input_vr[k]];
    FdModel model = {p, p->n_states, p->n_states + p->n_inputs, p->z, p->scale, p->rates, n_unknowns, evaluate,
                     known_index};
    *f = model;
    return p;
}
