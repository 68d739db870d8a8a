/* crankfmu's kernel (crank_kernel.h), its stepper: the Dormand-Prince step, its error norm, dense
 * output and event location on the tabulated model. The drivers callers run (crank_drivers.c),
 * the speed-causal step (crank_speed.c) and Model Exchange (crank_me.c) build on it
 * (crank_kernel_internal.h); the [[outputs]] and joint reactions read from their tables
 * (crank_outputs.c) and the kernel's constants and rules one by one (crank_facts.c) beside it. Written as the numba kernel it replaced, the same arithmetic in the
 * same order: the two gave the same numbers bit for bit on every case before numba went (commit
 * 3d63bb9). */
#include "crank_kernel_internal.h"

#include <math.h>
#include <string.h>

static const double SAFETY = 0.9, MIN_FACTOR = 0.2, MAX_FACTOR = 10.0;
/* kernel_locate's slot for the zero of slide friction 0's normal force (FRICTION_KINK - i: friction i) */
enum { FRICTION_KINK = -3 };
#define ERROR_EXPONENT (-1.0 / (CK_ERROR_ESTIMATOR_ORDER + 1))

/* (static: the hot path inlines it; ck_periodic_cubics is its exported face) */
static void periodic_cubics(const double* coefficients, int n_functions, int n, double period, double phi,
                            double* out)
{
    double h = period / n;
    double wrapped = phi - period * floor(phi / period);
    if (!isfinite(wrapped)) {          /* a state gone non-finite: NaN values, the step is refused */
        for (int f = 0; f < n_functions; f++) out[f] = NAN;
        return;
    }
    /* the interval index, clamped before the conversion: the rounding of a huge |phi| can put
     * wrapped outside [0, period), and an out-of-range conversion to int is undefined */
    double x = wrapped / h;
    int i = x <= 0.0 ? 0 : (x >= n ? n - 1 : (int)x);
    double u = wrapped - i * h;
    for (int f = 0; f < n_functions; f++) {
        const double* c = coefficients + ((size_t)f * n + i) * 4;
        out[f] = c[0] + u * (c[1] + u * (c[2] + u * c[3]));
    }
}

void ck_periodic_cubics(const double* coefficients, int n_functions, int n, double period, double phi, double* out)
{
    periodic_cubics(coefficients, n_functions, n, period, phi, out);
}

/* every tabulated function at phi into work[0:n_functions] */
static void table_values(const CkTables* T, double phi, double* work)
{
    periodic_cubics(T->coefficients, T->n_functions, T->n, T->period, phi, work);
}

/* the external torque on the crank at time t (N.m): tau_ext and each port's input times its
 * transfer function (work holds the tabulated functions at the crank angle) */
static double external_torque(double t, const CkTables* T, const double* P, const double* work)
{
    double dt = t - P[CK_T_INPUT];
    double tau = P[CK_TAU_EXT] + P[CK_TAU_EXT_RATE] * dt;
    const double* transfer = work + (T->n_functions - T->n_ports);
    for (int i = 0; i < T->n_ports; i++) tau += (P[CK_PORT_INPUT + i] + P[CK_PORT_RATE + i] * dt) * transfer[i];
    return tau;
}

/* (J, 0.5 J', Q) with the slider forces of the given interval and direction, and the external
 * torque at time t, without the joints' friction */
void kernel_coefficients_free(double t, double phi, double omega, double direction, double interval,
                              const CkTables* T, const double* P, double* work, double* J, double* half_dJ, double* Q,
                              double* tau)
{
    table_values(T, phi, work);
    *J = work[0] + P[CK_J_FLYWHEEL];
    double q = work[2] + work[3] * omega;
    const double* forces = T->forces + (size_t)interval * 2 * T->n_sliders;
    /* a law of the speed's column has the value 1 both ways, so that it acts in either direction and
     * at rest (ck_column_factor); ck_column_speed applies its law */
    for (int s = 0; s < T->n_sliders; s++)
        q += ck_column_factor(forces[s], forces[T->n_sliders + s], direction) * ck_column_speed(T, s, omega)
             * work[4 + s];
    *half_dJ = work[1];
    *Q = q;
    *tau = external_torque(t, T, P, work);
}

/* kernel_coefficients: with joint friction, Q holds the friction's generalised force at the speed
 * held (epsilon1 = 0: what the motor's switch and its sliding weigh), as the reference's
 * coefficients do */
void kernel_coefficients(double t, double phi, double omega, double direction, double interval, const CkTables* T,
                         const double* P, double* work, double* J, double* half_dJ, double* Q, double* tau)
{
    kernel_coefficients_free(t, phi, omega, direction, interval, T, P, work, J, half_dJ, Q, tau);
    if (T->friction != NULL && direction != 0.0)
        *Q += kernel_friction(t, phi, omega, direction, interval, T, P, *J, 0.0, 1, NULL, NULL);
}

static double motor_torque(double omega, int high, const double* P)
{
    if (high) return ck_line_torque(P[CK_A_], P[CK_B_], omega);
    return ck_line_torque(P[CK_A_LOW], P[CK_B_LOW], omega);
}

/* what a right-hand side gives besides dy/dt (rhs' extras; NULL: nothing) */
typedef struct {
    double M, Q, J, tau, friction;   /* N.m, N.m, kg.m2, N.m, N.m (the friction's generalised force) */
    double* f;                       /* the frictions (n_f), NULL: not wanted */
    double* normals;                 /* the slides' normal forces (n_f), NULL: not wanted */
} RhsExtras;

/* d/dt (phi1, omega1, W_motor, W_load, W_ext, W_friction) into out; returns epsilon1 */
static double rhs(double t, double phi, double omega, double motor, double direction, double interval,
                  const CkTables* T, const double* P, double* work, double* out, RhsExtras* x)
{
    double J, half_dJ, Q, M, eps, tau, friction = 0.0;
    kernel_coefficients_free(t, phi, omega, direction, interval, T, P, work, &J, &half_dJ, &Q, &tau);
    if (direction == 0.0) {
        M = motor_torque(0.0, motor == CK_HIGH, P);
        eps = 0.0;
        omega = 0.0;
        if (x && T->friction)
            for (int i = 0; i < T->friction->n_f; i++) {
                if (x->f) x->f[i] = 0.0;
                if (x->normals) x->normals[i] = NAN;
            }
    } else if (motor == CK_SLIDE) {
        if (T->friction)
            friction = kernel_friction(t, phi, omega, direction, interval, T, P, J, 0.0, 1, x ? x->f : NULL,
                                       x ? x->normals : NULL);
        M = ck_equivalent_torque(half_dJ, Q + friction, tau, omega);
        eps = 0.0;
    } else {
        M = motor_torque(omega, motor == CK_HIGH, P);
        eps = ck_acceleration(J, half_dJ, Q, M, tau, omega);
        if (T->friction) {
            friction = kernel_friction(t, phi, omega, direction, interval, T, P, J, eps, 0, x ? x->f : NULL,
                                       x ? x->normals : NULL);
            eps += friction / J;
        }
    }
    out[0] = omega;
    out[1] = eps;
    out[2] = M * omega;
    out[3] = Q * omega;
    out[4] = tau * omega;
    out[5] = friction * omega;
    if (x) {
        x->M = M;
        x->Q = Q;
        x->J = J;
        x->tau = tau;
        x->friction = friction;
    }
    return eps;
}

int kernel_friction_normals(const double* S, double t, const double* y, const CkTables* T, const double* P,
                            double* normals)
{
    const CkFriction* F = T->friction;
    int slides = 0;
    for (int i = 0; F && i < F->n_f; i++) slides += F->components[i] == 1;
    if (!slides) return 0;
    double work[CK_MAX_FUNCTIONS], out[CK_N_Y];
    RhsExtras x = {0.0, 0.0, 0.0, 0.0, 0.0, NULL, normals};
    rhs(t, y[0], y[1], S[CK_MOTOR], S[CK_DIRECTION], S[CK_INTERVAL], T, P, work, out, &x);
    return 1;
}

void ck_dense(const double* S, double t, double* out)
{
    double h = S[CK_T] - S[CK_T_PREV];
    if (t == S[CK_T] || h == 0.0) {
        for (int j = 0; j < CK_N_Y; j++) out[j] = S[CK_Y + j];
        return;
    }
    double x = (t - S[CK_T_PREV]) / h;
    double p0 = x, p1 = x * x, p2 = x * x * x, p3 = x * x * x * x;
    for (int j = 0; j < CK_N_Y; j++) {
        double acc = 0.0;
        for (int s = 0; s < CK_N_STAGES + 1; s++)
            acc += S[CK_K + CK_N_Y * s + j] * (CK_P[s][0] * p0 + CK_P[s][1] * p1 + CK_P[s][2] * p2 + CK_P[s][3] * p3);
        out[j] = S[CK_Y_PREV + j] + h * acc;
    }
}

/* motor branch from a state on omega1 = omega_switch */
static double mode_on_switch(double t, double phi, double direction, double interval, const CkTables* T,
                             const double* P, double* work)
{
    double ws = P[CK_OMEGA_SWITCH], J, half_dJ, Q, tau;
    kernel_coefficients(t, phi, ws, direction, interval, T, P, work, &J, &half_dJ, &Q, &tau);
    double rest = Q + tau - half_dJ * ws * ws;
    return ck_motor_on_switch(motor_torque(ws, 0, P), motor_torque(ws, 1, P), rest);
}

/* the crank's acceleration from rest with the slider forces forward (eps[0]) and backward (eps[1]) */
void kernel_rest_accelerations(double t, double phi, double motor, double interval, const CkTables* T,
                               const double* P, double* work, double* f, double* eps)
{
    eps[0] = rhs(t, phi, 0.0, motor, 1.0, interval, T, P, work, f, NULL);
    eps[1] = rhs(t, phi, 0.0, motor, -1.0, interval, T, P, work, f, NULL);
}

double kernel_direction_at_rest(double t, double phi, double motor, double interval, const CkTables* T,
                                const double* P, double* work, double* f)
{
    double eps[2];
    kernel_rest_accelerations(t, phi, motor, interval, T, P, work, f, eps);
    return ck_direction_at_rest(eps[0], eps[1]);
}

void kernel_set_interval(double* S, const CkTables* T, double phi, double direction)
{
    double lo, hi;
    int k = ck_interval_of(T->switch_angles, T->m, phi, direction, &lo, &hi);
    S[CK_INTERVAL] = (double)k;
    S[CK_PHI_LO] = lo;
    S[CK_PHI_HI] = hi;
}

/* the discrete state (motor branch, direction, switch interval) of a start or a restart at (S[CK_T], y) */
void kernel_set_mode(double* S, const double* y, const CkTables* T, const double* P, Scratch* w)
{
    double t = S[CK_T];
    double omega = y[1], ws = P[CK_OMEGA_SWITCH];
    double motor = ck_motor_of_speed(omega, ws);
    double direction = ck_direction_of_speed(omega);
    kernel_set_interval(S, T, y[0], direction);
    if (omega == ws) motor = mode_on_switch(t, y[0], direction, S[CK_INTERVAL], T, P, w->work);
    if (omega == 0.0 && ck_switched(T)) {
        direction = kernel_direction_at_rest(t, y[0], motor, S[CK_INTERVAL], T, P, w->work, w->f);
        kernel_set_interval(S, T, y[0], direction != 0.0 ? direction : 1.0);
    }
    S[CK_MOTOR] = motor;
    S[CK_DIRECTION] = direction;
}

void kernel_start(double* S, double t, const double* y, const CkTables* T, const double* P, Scratch* w)
{
    S[CK_T] = t;
    for (int j = 0; j < CK_N_Y; j++) {
        S[CK_Y + j] = y[j];
        S[CK_Y_PREV + j] = y[j];
    }
    S[CK_T_PREV] = t;
    kernel_set_mode(S, y, T, P, w);
    double motor = S[CK_MOTOR], direction = S[CK_DIRECTION];
    rhs(t, y[0], y[1], motor, direction, S[CK_INTERVAL], T, P, w->work, w->f, NULL);
    for (int j = 0; j < CK_N_Y; j++) {
        S[CK_F + j] = w->f[j];
        for (int s = 0; s < CK_N_STAGES + 1; s++) S[CK_K + CK_N_Y * s + j] = s == CK_N_STAGES ? w->f[j] : 0.0;
    }
    double d0 = 0.0, d1 = 0.0;
    for (int j = 0; j < CK_N_PLAIN; j++) {
        double scale = P[CK_ATOL] + P[CK_RTOL] * fabs(y[j]);
        d0 += (y[j] / scale) * (y[j] / scale);
        d1 += (w->f[j] / scale) * (w->f[j] / scale);
    }
    d0 = sqrt(d0 / 5.0);
    d1 = sqrt(d1 / 5.0);
    double h = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    S[CK_H] = fmin(h, P[CK_H_MAX]);
    S[CK_N_RHS] += 1.0;
    S[CK_STEP_MOTOR] = motor;
    S[CK_STEP_DIRECTION] = direction;
    S[CK_STEP_INTERVAL] = S[CK_INTERVAL];
}

/* one Dormand-Prince step from (t, y, f) in S's mode; stages into w->Kst */
static void rk_step(const double* S, double t, const double* y, const double* f, double h, const CkTables* T,
                    const double* P, Scratch* w)
{
    double motor = S[CK_MOTOR], direction = S[CK_DIRECTION], interval = S[CK_INTERVAL];
    for (int j = 0; j < CK_N_Y; j++) w->Kst[0][j] = f[j];
    for (int s = 1; s < CK_N_STAGES; s++) {
        for (int j = 0; j < CK_N_Y; j++) {
            double acc = 0.0;
            for (int r = 0; r < s; r++) acc += w->Kst[r][j] * CK_A[s][r];
            w->tmp[j] = y[j] + h * acc;
        }
        rhs(t + CK_C[s] * h, w->tmp[0], w->tmp[1], motor, direction, interval, T, P, w->work, w->Kst[s], NULL);
    }
    for (int j = 0; j < CK_N_Y; j++) {
        double acc = 0.0;
        for (int r = 0; r < CK_N_STAGES; r++) acc += w->Kst[r][j] * CK_B[r];
        w->ynew[j] = y[j] + h * acc;
    }
    rhs(t + h, w->ynew[0], w->ynew[1], motor, direction, interval, T, P, w->work, w->Kst[CK_N_STAGES], NULL);
}

static double error_norm(const double* y, const double* ynew, const Scratch* w, double h, const double* P, int n_norm)
{
    /* W_friction joins the norm only where there is friction: without, the norm is the one the
     * kernel had before friction existed (and steps bit for bit as then) */
    double acc = 0.0;
    for (int j = 0; j < n_norm; j++) {
        double e = 0.0;
        for (int s = 0; s < CK_N_STAGES + 1; s++) e += w->Kst[s][j] * CK_E[s];
        double scale = P[CK_ATOL] + P[CK_RTOL] * fmax(fabs(y[j]), fabs(ynew[j]));
        double r = h * e / scale;
        acc += r * r;
    }
    return sqrt(acc / n_norm);
}

/* event functions of S's mode at (t, y) into g; inactive slots get NaN */
void kernel_events(const double* S, double t, const double* y, const CkTables* T, const double* P, double* work,
                   double* g)
{
    double motor = S[CK_MOTOR], direction = S[CK_DIRECTION], ws = P[CK_OMEGA_SWITCH];
    double m_low = 0.0, m_high = 0.0, equivalent = 0.0;
    if (motor == CK_SLIDE) {
        double J, half_dJ, Q, tau;
        kernel_coefficients(t, y[0], ws, direction, S[CK_INTERVAL], T, P, work, &J, &half_dJ, &Q, &tau);
        equivalent = ck_equivalent_torque(half_dJ, Q, tau, ws);
        m_low = motor_torque(ws, 0, P);
        m_high = motor_torque(ws, 1, P);
    }
    int has_sliders = ck_switched(T);
    for (int slot = 0; slot < CK_N_SLOTS; slot++) {
        if (ck_event_active(slot, motor, direction, S[CK_PHI_HI], has_sliders, ws))
            g[slot] = ck_event_value(slot, y[0], y[1], motor, S[CK_PHI_LO], S[CK_PHI_HI], ws, m_low, m_high,
                                     equivalent);
        else
            g[slot] = NAN;
    }
}

/* discrete state after the event in slot at (t, y) (y adjusted onto the surface) */
void kernel_transition(double* S, int slot, double t, double* y, const CkTables* T, const double* P, double* work,
                       double* f)
{
    double ws = P[CK_OMEGA_SWITCH];
    if (slot == CK_INTERVAL_END || slot == CK_INTERVAL_START) {
        int forward = slot == CK_INTERVAL_END;
        y[0] = forward ? S[CK_PHI_HI] : S[CK_PHI_LO];
        double lo = S[CK_PHI_LO], hi = S[CK_PHI_HI];
        int k = ck_next_interval(T->switch_angles, T->m, (int)S[CK_INTERVAL], &lo, &hi, forward);
        S[CK_INTERVAL] = (double)k;
        S[CK_PHI_LO] = lo;
        S[CK_PHI_HI] = hi;
        return;
    }
    y[1] = slot == CK_REST ? 0.0 : ws;
    if (slot == CK_REST) S[CK_MOTOR] = ck_motor_at_rest(S[CK_MOTOR], ws);
    if (ck_turns_forces(slot, ws, ck_switched(T)))
        S[CK_DIRECTION] = kernel_direction_at_rest(t, y[0], S[CK_MOTOR], S[CK_INTERVAL], T, P, work, f);
    if (slot == CK_REST) return;
    if (S[CK_MOTOR] == CK_SLIDE)
        S[CK_MOTOR] = ck_motor_after_sliding(slot);
    else
        S[CK_MOTOR] = mode_on_switch(t, y[0], S[CK_DIRECTION], S[CK_INTERVAL], T, P, work);
}

/* sign-true slope of omega1 (h domega1/dt) at x in [0, 1] of the last step's interpolant */
double kernel_omega_slope(const double* S, double x)
{
    double acc = 0.0;
    for (int s = 0; s < CK_N_STAGES + 1; s++)
        acc += S[CK_K + CK_N_Y * s + 1] * (CK_P[s][0] + x * (2.0 * CK_P[s][1] + x * (3.0 * CK_P[s][2] + x * 4.0 * CK_P[s][3])));
    return acc;
}

/* time in [lo, hi] of the last step where g changes sign, by Illinois on the dense output: g is
 * event slot `slot` of S's mode, phi1 - level for slot -1, the slope of omega1 for slot -2, the
 * normal force of slide friction i for slot FRICTION_KINK - i */
double kernel_locate(const double* S, int slot, double level, double lo, double hi, double glo, double ghi,
                     const CkTables* T, const double* P, double* work, double* tmp, double* g)
{
    for (int it = 0; it < 60; it++) {
        double tm = hi - ghi * (hi - lo) / (ghi - glo);
        if (!(lo < tm && tm < hi)) tm = 0.5 * (lo + hi);
        ck_dense(S, tm, tmp);
        double gm;
        if (slot == -2)
            gm = kernel_omega_slope(S, (tm - S[CK_T_PREV]) / (S[CK_T] - S[CK_T_PREV]));
        else if (slot == -1)
            gm = tmp[0] - level;
        else if (slot <= FRICTION_KINK) {
            double normals[CK_MAX_FRICTIONS];
            kernel_friction_normals(S, tm, tmp, T, P, normals);
            gm = normals[FRICTION_KINK - slot];
        }
        else {
            kernel_events(S, tm, tmp, T, P, work, g);
            gm = g[slot];
        }
        if ((gm < 0.0) == (glo < 0.0)) {
            lo = tm;
            glo = gm;
            ghi *= 0.5;
        } else {
            hi = tm;
            ghi = gm;
            glo *= 0.5;
        }
        if (hi - lo <= 1e-15 * fmax(1.0, fabs(hi))) break;
    }
    return hi;
}

static int mode_ok(double motor, double direction, double k, const CkTables* T)
{
    if (!(motor == CK_LOW || motor == CK_HIGH || motor == CK_SLIDE)) return 0;
    if (!(direction == 1.0 || direction == -1.0 || direction == 0.0)) return 0;
    if (T->m == 0) return k == 0.0;
    return k >= 0.0 && k < T->m && k == floor(k);
}

/* whether S's discrete state is one the kernel can have written: a motor branch, a direction, a
 * switch interval of these tables, now and over the last step (the output row inside the last
 * step reads the step's; a state a host corrupted or deserialized from damaged bytes is refused,
 * never indexed with) */
int kernel_mode_ok(const double* S, const CkTables* T)
{
    return mode_ok(S[CK_MOTOR], S[CK_DIRECTION], S[CK_INTERVAL], T)
           && mode_ok(S[CK_STEP_MOTOR], S[CK_STEP_DIRECTION], S[CK_STEP_INTERVAL], T);
}

/* the slide friction whose normal force crosses zero first in the step just taken (S holds it: t to
 * t_new) before t_before, its time into w->g1[0]; -1: none. A zero at the step's start is the last
 * step's end (it ended on it): not found again. */
static int kink_in_step(const double* S, double t, double t_new, Scratch* w, const CkTables* T, const double* P,
                        double t_before)
{
    double n0[CK_MAX_FRICTIONS], n1[CK_MAX_FRICTIONS];
    if (!kernel_friction_normals(S, t, w->y, T, P, n0)) return -1;
    kernel_friction_normals(S, t_new, w->ynew, T, P, n1);
    int found = -1;
    double first = t_before;
    for (int i = 0; i < T->friction->n_f; i++) {
        if (!(isfinite(n0[i]) && isfinite(n1[i])) || !((n0[i] < 0.0 && n1[i] > 0.0) || (n0[i] > 0.0 && n1[i] < 0.0)))
            continue;
        double at = kernel_locate(S, FRICTION_KINK - i, 0.0, t, t_new, n0[i], n1[i], T, P, w->work, w->tmp, w->g0);
        /* (a zero within a millionth of the step from its start: the one the last step ended on,
         * N's round-off on the wrong side of it) */
        if (at - t <= fmax(1e-12 * fmax(1.0, fabs(t)), 1e-6 * (t_new - t)) || at >= first) continue;
        found = i;
        first = at;
    }
    if (found >= 0) w->g1[0] = first;
    return found;
}

/* one accepted step, not beyond t_limit, ending on the first event crossed */
int kernel_step(double* S, double t_limit, const CkTables* T, const double* P, Scratch* w)
{
    if (!kernel_mode_ok(S, T)) return CK_BAD_STATE;
    double t = S[CK_T];
    for (int j = 0; j < CK_N_Y; j++) {
        w->y[j] = S[CK_Y + j];
        w->f0[j] = S[CK_F + j];
    }
    double h = fmin(S[CK_H], P[CK_H_MAX]);
    double n_rhs = S[CK_N_RHS];
    double err = 0.0;
    int to_limit;
    for (;;) {
        /* a step clipped to the limit ends on it exactly: t + (t_limit - t) can miss t_limit by an
         * ulp, and the ulp left would be an underflow on the next step */
        to_limit = t + h >= t_limit;
        if (to_limit) h = t_limit - t;
        if (h <= 1e-14 * fmax(1.0, fabs(t))) return CK_UNDERFLOW;
        rk_step(S, t, w->y, w->f0, h, T, P, w);
        n_rhs += CK_N_STAGES;
        err = error_norm(w->y, w->ynew, w, h, P, T->friction ? CK_N_Y : CK_N_PLAIN);
        if (err <= 1.0) break;
        h *= fmax(MIN_FACTOR, SAFETY * pow(err, ERROR_EXPONENT));
    }
    double factor = err == 0.0 ? MAX_FACTOR : fmin(MAX_FACTOR, SAFETY * pow(err, ERROR_EXPONENT));
    double h_next = fmin(h * factor, P[CK_H_MAX]);
    /* with no limit (no stop time, no largest step) a step whose error is exactly zero (a crank at
     * rest) grows tenfold each time: kept finite, for an infinite step would never be accepted and
     * never shrink (inf * 0.2) */
    if (!isfinite(h_next)) h_next = h;
    double t_new = to_limit ? t_limit : t + h;

    kernel_events(S, t, w->y, T, P, w->work, w->g0);
    kernel_events(S, t_new, w->ynew, T, P, w->work, w->g1);
    S[CK_T_PREV] = t;
    S[CK_T] = t_new;
    for (int j = 0; j < CK_N_Y; j++) {
        S[CK_Y_PREV + j] = w->y[j];
        S[CK_Y + j] = w->ynew[j];
        for (int s = 0; s < CK_N_STAGES + 1; s++) S[CK_K + CK_N_Y * s + j] = w->Kst[s][j];
    }
    S[CK_STEP_MOTOR] = S[CK_MOTOR];
    S[CK_STEP_DIRECTION] = S[CK_DIRECTION];
    S[CK_STEP_INTERVAL] = S[CK_INTERVAL];
    int first_slot = -1;
    double first_t = t_new;
    for (int slot = 0; slot < CK_N_SLOTS; slot++) {
        double a = w->g0[slot], b = w->g1[slot];
        if (!ck_crosses(a, b, ck_event_rising(slot, S[CK_MOTOR], S[CK_DIRECTION]))) continue;
        /* g1 is the search's scratch: a later slot reads its value at the earlier slot's event,
         * which suffices (only a crossing before that event can end the step) */
        double hi = kernel_locate(S, slot, 0.0, t, t_new, a, b, T, P, w->work, w->tmp, w->g1);
        if (first_slot < 0 || hi < first_t) {
            first_slot = slot;
            first_t = hi;
        }
    }
    /* a slide's friction mu |N| has a kink where its normal force N passes through zero (several
     * times a turn in a slider-crank): not a switch (|N| is continuous, and nothing in the mode
     * changes), but a step across it loses the method's order, and where the error control then
     * lands decides the result to 1e-8. The step ends on it instead, located as an event is. */
    int kink = kink_in_step(S, t, t_new, w, T, P, first_slot < 0 ? t_new : first_t);
    if (kink >= 0) {
        first_t = w->g1[0];
        first_slot = -1;
    }
    if (first_slot < 0 && kink < 0) {
        for (int j = 0; j < CK_N_Y; j++) S[CK_F + j] = w->Kst[CK_N_STAGES][j];
        S[CK_H] = h_next;
        S[CK_N_RHS] = n_rhs;
        S[CK_N_STEPS] += 1.0;
        return CK_NO_EVENT;
    }
    /* recompute the step so that it ends on the event, then change mode there */
    double h_event = first_t - t;
    rk_step(S, t, w->y, w->f0, h_event, T, P, w);
    n_rhs += CK_N_STAGES;
    S[CK_T] = first_t;
    for (int j = 0; j < CK_N_Y; j++)
        for (int s = 0; s < CK_N_STAGES + 1; s++) S[CK_K + CK_N_Y * s + j] = w->Kst[s][j];
    if (first_slot >= 0) kernel_transition(S, first_slot, first_t, w->ynew, T, P, w->work, w->f);
    rhs(first_t, w->ynew[0], w->ynew[1], S[CK_MOTOR], S[CK_DIRECTION], S[CK_INTERVAL], T, P, w->work, w->f, NULL);
    for (int j = 0; j < CK_N_Y; j++) {
        S[CK_Y + j] = w->ynew[j];
        S[CK_F + j] = w->f[j];
    }
    S[CK_H] = fmax(h_next, h_event);
    S[CK_N_RHS] = n_rhs + 1.0;
    S[CK_N_STEPS] += 1.0;
    return first_slot >= 0 ? first_slot : CK_NO_EVENT;
}

/* the rest of an output row whose state row[0:5] at time t is set, in the given mode: epsilon1,
 * M_motor, M_load, J_red, tau_e; f <- dy/dt there */
void kernel_complete_row(double t, double motor, double direction, double interval, const CkTables* T,
                         const double* P, double* work, double* f, double* row)
{
    RhsExtras x = {0.0, 0.0, 0.0, 0.0, 0.0, NULL, NULL};
    row[CK_OUT_W_FRICTION] = row[CK_W_FRICTION];
    double eps = rhs(t, row[0], row[1], motor, direction, interval, T, P, work, f, &x);
    row[5] = eps;
    row[6] = x.M;
    row[7] = x.Q;
    row[8] = x.J;
    row[9] = x.tau;
    row[CK_OUT_M_FRICTION] = x.friction;
}

void kernel_output_row(const double* S, double t, const CkTables* T, const double* P, double* work, double* f,
                       double* row)
{
    ck_dense(S, t, row);
    const double* mode = kernel_mode_at(S, t);
    kernel_complete_row(t, mode[0], mode[1], mode[2], T, P, work, f, row);
}
