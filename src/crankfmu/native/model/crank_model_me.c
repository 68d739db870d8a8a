/* Model Exchange for the native mechanism FMU (crank_model.h's cm_me_...): the host integrates the
 * kernel's y (phi1, omega1 and the three works); the model keeps the mode in the kernel's state
 * array and hands the host the kernel's derivatives, event indicators (with hysteresis) and event
 * update. Each call refuses a Co-Simulation instance and one outside the phases it allows. */
#include "crank_model_internal.h"

#include <math.h>
#include <string.h>

int cm_me_ready(Model* m, const char* call, int initialization_too)
{
    if (!m->model_exchange) return cm_fail(m, "%s: this instance is Co-Simulation", call);
    if (m->now.phase == CM_STEPPING || (initialization_too && m->now.phase == CM_INITIALIZATION))
        return cm_ensure_tables(m, call);
    char why[160];
    return cm_fail(m, "%s: %s", call, cm_cannot(m, call, why, sizeof why));
}

/* in initialisation, the values the start values give */
static void me_current(Model* m)
{
    if (m->now.phase == CM_INITIALIZATION) {
        cm_me_start(m);
        cm_me_evaluate(m);
    }
}

int cm_me_update(Model* m, const char* call, int* states_changed)
{
    if (cm_me_ready(m, call, 0) != CM_OK) return CM_ERROR;
    double* S = m->now.S;
    double before[CK_N_Y];
    memcpy(before, S + CK_Y, sizeof before);
    if (m->now.pending) {           /* a tunable changed (cm_set loaded it): the mode as a restart finds it */
        ck_me_mode(S, S + CK_Y, &m->tables, m->now.P);
        m->now.pending = 0;
    }
    int transitions = ck_me_update(S, S + CK_Y, &m->tables, m->now.P);
    if (transitions < 0 || !cm_me_evaluate(m)) {
        m->now.phase = CM_FAILED;
        return cm_stop(m, "%s: the event update failed at t = %.9g s (%s)", call, m->now.time,
                       transitions == CK_NO_FIXED_POINT ? "the mode transitions do not settle"
                       : transitions == CK_BAD_STATE    ? "a corrupted state"
                                                        : "non-finite derivatives or outputs");
    }
    *states_changed = memcmp(before, S + CK_Y, sizeof before) != 0;
    return CM_OK;
}

int cm_me_set_time(Model* m, const char* call, double time)
{
    if (cm_me_ready(m, call, 1) != CM_OK) return CM_ERROR;
    if (!isfinite(time)) return cm_fail(m, "%s: the time must be finite", call);
    m->now.time = time;               /* the inputs' rates are 0 here: the right-hand side does not depend on t */
    m->now.S[CK_T] = time;
    return CM_OK;
}

/* a call that passes one value per continuous state; in initialisation (where allowed), the
 * values brought to what the start values give */
static int states_call(Model* m, const char* call, int initialization_too, const void* array, size_t n)
{
    if (cm_me_ready(m, call, initialization_too) != CM_OK) return CM_ERROR;
    if (n != (size_t)m->d->n_states)
        return cm_fail(m, "%s: this FMU has %d continuous states, not %u", call, m->d->n_states, (unsigned)n);
    if (!array) return cm_fail(m, "%s: null array", call);
    me_current(m);
    return CM_OK;
}

int cm_me_set_states(Model* m, const char* call, const double* x, size_t n)
{
    if (states_call(m, call, 0, x, n) != CM_OK) return CM_ERROR;
    static const char* const names[CK_N_Y] = {"phi1", "omega1", "W_motor", "W_load", "W_ext", "W_friction"};
    for (size_t j = 0; j < n; j++)
        if (!isfinite(x[j])) return cm_fail(m, "%s: state %u (%s) is not finite", call, (unsigned)j, names[j]);
    memcpy(m->now.S + CK_Y, x, n * sizeof(double));
    if (!cm_me_evaluate(m))
        return cm_fail(m, "%s: the state at t = %.9g s gives non-finite derivatives", call, m->now.time);
    return CM_OK;
}

int cm_me_get_states(Model* m, const char* call, double* x, size_t n)
{
    if (states_call(m, call, 1, x, n) != CM_OK) return CM_ERROR;
    memcpy(x, m->now.S + CK_Y, n * sizeof(double));
    return CM_OK;
}

int cm_me_get_derivatives(Model* m, const char* call, double* dx, size_t n)
{
    if (states_call(m, call, 1, dx, n) != CM_OK) return CM_ERROR;
    memcpy(dx, m->now.dydt, n * sizeof(double));
    return CM_OK;
}

int cm_me_get_indicators(Model* m, const char* call, double* z, size_t n)
{
    if (cm_me_ready(m, call, 1) != CM_OK) return CM_ERROR;
    if (n != CK_N_SLOTS) return cm_fail(m, "%s: this FMU has %d event indicators, not %u", call, CK_N_SLOTS, (unsigned)n);
    if (!z) return cm_fail(m, "%s: null array", call);
    me_current(m);
    if (ck_me_indicators(m->now.S, m->now.S + CK_Y, &m->tables, m->now.P, z) != 0)
        return cm_fail(m, "%s: a corrupted state", call);
    return CM_OK;
}

int cm_me_get_nominals(Model* m, const char* call, double* nominals, size_t n)
{
    if (states_call(m, call, 1, nominals, n) != CM_OK) return CM_ERROR;
    for (size_t j = 0; j < n; j++) nominals[j] = 1.0;
    return CM_OK;
}
