/* The native mechanism FMU's derivatives for masters (crank_model.h's cm_jacobian and
 * cm_output_derivatives), on one view of its equations at the current point: z = (the continuous
 * states, then the inputs), the mode held.
 *
 * Torque causality: z = (phi1, omega1, W_motor, W_load, W_ext, tau_ext, the ports' inputs); the
 * equations are the kernel's right-hand side and output row (ck_me_derivatives) with the
 * [[outputs]] and joint reactions from their tables, as Model Exchange evaluates them.
 * Speed causality: z = (phi1, W_drive, W_load, W_ext, omega1, the ports' inputs); the row is the
 * one a step starting here would give at its start (ck_speed_row), epsilon1 the slope that step
 * takes: the input's derivative where the host gave one, else omega1's change since the last
 * step's start over that step (so tau_drive depends on the omega1 just set, by J epsilon1). Along
 * the trajectory that slope is held, as the step holds it. */
#include "crank_model_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_derivatives.h"

enum { MAX_Z = CK_N_Y + CM_MAX_INPUTS };

typedef struct {
    Model base;                 /* the model at the current point: its mode, time and parameters */
    Model trial;                /* the same at a trial z */
    const unsigned* unknowns;
    size_t n_unknowns;
    int n_states, n_inputs;
    int slope_held;             /* speed causality: epsilon1 the current slope, whatever omega1 is */
    double slope;
    double z[MAX_Z], scale[MAX_Z], rates[CM_MAX_INPUTS];
} Point;

static int input_vr(const Model* m, int k) { return k == 0 ? m->d->vr_crank_input : m->d->vr_first_port + k - 1; }

/* the speed-causal step's slope for the input omega1 (the kernel's rule) */
static double speed_slope(const Model* m, double omega)
{
    return ck_speed_slope(m->now.S, omega, m->now.input_rate[0], m->now.rate_given[0]);
}

static int evaluate(void* model, const double* z, double* values, double* rates)
{
    Point* p = (Point*)model;
    Model* t = &p->trial;
    *t = p->base;
    for (int k = 0; k < p->n_inputs; k++) t->now.values[input_vr(t, k)] = z[p->n_states + k];
    cm_load_parameters(t);
    double* S = t->now.S;
    if (t->d->causality_speed) {
        double omega = z[p->n_states];
        S[CK_Y] = z[0];
        S[CK_Y + 1] = omega;
        for (int j = 1; j < 4; j++) S[CK_Y + 1 + j] = z[j];
        S[CK_F + 1] = p->slope_held ? p->slope : speed_slope(&p->base, omega);
        ck_speed_row(S, &t->tables, t->now.P, t->now.row);
        if (rates) {
            const double* row = t->now.row;
            rates[0] = omega;
            rates[1] = row[ROW_M_MOTOR] * omega;
            rates[2] = row[ROW_M_LOAD] * omega;
            rates[3] = row[ROW_TAU_E] * omega;
        }
    } else {
        memcpy(S + CK_Y, z, sizeof(double) * p->n_states);
        if (ck_me_derivatives(S, S + CK_Y, &t->tables, t->now.P, t->now.dydt, t->now.row) != 0) return -1;
        if (rates) memcpy(rates, t->now.dydt, sizeof(double) * p->n_states);
    }
    for (int j = 0; j < CK_OUT_SIZE; j++)
        if (!isfinite(t->now.row[j])) return -1;
    if (values) cm_read_values(t, p->unknowns, p->n_unknowns, values);
    return 0;
}

/* the current point of a stepping model (its tables checked): z, the mode and time in p->base */
static int point_of(Model* m, const char* call, Point* p)
{
    if (m->now.phase != CM_STEPPING) {
        char why[160];
        return cm_fail(m, "%s: %s", call, cm_cannot(m, call, why, sizeof why));
    }
    if (cm_ensure_tables(m, call) != CM_OK) return CM_ERROR;
    p->base = *m;
    const ModelData* d = m->d;
    double* S = p->base.now.S;
    p->n_inputs = d->n_inputs;
    p->slope_held = 0;
    if (d->causality_speed) {
        p->n_states = 4;
        double omega = m->now.values[d->vr_crank_input];
        p->slope = speed_slope(m, omega);
        p->z[0] = S[CK_Y];
        for (int j = 1; j < 4; j++) p->z[j] = S[CK_Y + 1 + j];
        p->scale[0] = 1.0;
    } else {
        p->n_states = d->n_states;
        /* Co-Simulation: the kernel may have stepped past the communication point */
        if (!m->model_exchange) ck_point(m->now.S, m->now.time, S);
        memcpy(p->z, S + CK_Y, sizeof(double) * d->n_states);
        p->scale[0] = 1.0;              /* phi1: the tables' cubics vary over a fraction of a radian */
    }
    for (int j = 1; j < p->n_states; j++) p->scale[j] = fmax(1.0, fabs(p->z[j]));
    for (int k = 0; k < p->n_inputs; k++) {
        p->z[p->n_states + k] = m->now.values[input_vr(m, k)];
        p->scale[p->n_states + k] = fmax(1.0, fabs(p->z[p->n_states + k]));
    }
    return CM_OK;
}

/* z's index of a known's value reference: a continuous state (the output that is one) or an
 * input; -1 otherwise */
static int known_index(void* point, unsigned vr)
{
    const Point* p = (const Point*)point;
    const Model* m = &p->base;
    const ModelData* d = m->d;
    if (vr >= (unsigned)d->n_variables) return -1;
    for (int k = 0; k < p->n_inputs; k++)
        if ((int)vr == input_vr(m, k)) return p->n_states + k;
    if (!d->causality_speed && d->n_states == CK_N_Y && (int)vr == d->vr_first_friction + FRICTION_W)
        return CK_W_FRICTION;                    /* W_friction, the friction's state */
    if ((int)vr >= d->n_outputs || d->variables[vr].kind != KIND_OUTPUT) return -1;
    int row = d->output_row[vr];
    if (d->causality_speed) return row == ROW_PHI1 ? 0 : row >= ROW_W_MOTOR && row <= ROW_W_EXT ? row - 1 : -1;
    return row >= 0 && row < CK_N_PLAIN ? row : -1;
}

void* cm_point(Model* m, const char* call, const unsigned* unknowns, size_t n_unknowns, int trajectory, FdModel* f)
{
    if (trajectory && m->model_exchange) {
        cm_fail(m, "%s: Co-Simulation only (a Model Exchange host has the states' derivatives)", call);
        return NULL;
    }
    for (size_t i = 0; i < n_unknowns; i++) {
        if (unknowns[i] >= (unsigned)m->d->n_variables) {
            cm_fail(m, "%s: no variable has value reference %u", call, unknowns[i]);
            return NULL;
        }
        int kind = m->d->variables[unknowns[i]].kind;
        if (!(kind == KIND_OUTPUT || kind == KIND_QUANTITY || kind == KIND_REACTION || kind == KIND_FRICTION ||
              (!trajectory && kind == KIND_DERIVATIVE))) {
            cm_fail(m, "%s: %s is not %s", call, m->d->variables[unknowns[i]].name,
                    trajectory ? "an output" : "an output or a state's derivative");
            return NULL;
        }
    }
    Point* p = (Point*)malloc(sizeof(Point));
    if (!p) {
        cm_fail(m, "%s: out of memory", call);
        return NULL;
    }
    if (point_of(m, call, p) != CM_OK) {
        free(p);
        return NULL;
    }
    p->unknowns = unknowns;
    p->n_unknowns = n_unknowns;
    for (int k = 0; k < p->n_inputs; k++) p->rates[k] = m->now.input_rate[k];
    if (trajectory && m->d->causality_speed) {     /* omega1 follows the next step's line */
        p->slope_held = 1;
        p->rates[0] = p->slope;
    }
    FdModel model = {p, p->n_states, p->n_states + p->n_inputs, p->z, p->scale, p->rates, n_unknowns, evaluate,
                     known_index};
    *f = model;
    return p;
}
