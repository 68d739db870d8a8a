/* The kernel's drivers (crank_kernel.h): an FMU step, a run on an output grid, the dense output
 * of many times, and the steady cycles of many designs, on the stepper (crank_kernel.c). */
#include "crank_kernel_internal.h"

#include <math.h>
#include <string.h>

/* ------------------------------------------------------------------------------ the drivers */

/* the output row at t in the last step, NaN for a state the kernel cannot have written */
static void checked_output_row(const double* S, double t, const CkTables* T, const double* P, double* row)
{
    Scratch w;
    if (!kernel_mode_ok(S, T)) {
        for (int j = 0; j < CK_OUT_SIZE; j++) row[j] = NAN;
        return;
    }
    kernel_output_row(S, t, T, P, w.work, w.f, row);
}

void ck_point(const double* S, double t, double* out)
{
    memcpy(out, S, CK_STATE_SIZE * sizeof(double));
    if (t == S[CK_T]) return;
    ck_dense(S, t, out + CK_Y);
    memcpy(out + CK_MOTOR, kernel_mode_at(S, t), 3 * sizeof(double));
    out[CK_T] = t;
}

void ck_begin(double* S, double t, const double* y, const CkTables* T, const double* P, double* row)
{
    Scratch w;
    kernel_start(S, t, y, T, P, &w);
    kernel_output_row(S, t, T, P, w.work, w.f, row);
}

int ck_advance(double* S, double t_target, double t_limit, const CkTables* T, const double* P, double* row)
{
    Scratch w;
    for (long n = 0; S[CK_T] < t_target; n++) {
        if (n >= CK_MAX_STEPS_PER_CALL) return CK_TOO_MANY_STEPS;
        int slot = kernel_step(S, t_limit, T, P, &w);
        if (slot == CK_UNDERFLOW || slot == CK_BAD_STATE) return slot;
    }
    checked_output_row(S, t_target, T, P, row);
    return 0;
}

int ck_advance_to_switch(double* S, double t_target, double t_limit, const CkTables* T, const double* P, double* row,
                         double* t_switch)
{
    Scratch w;
    for (long n = 0; S[CK_T] < t_target; n++) {
        if (n >= CK_MAX_STEPS_PER_CALL) return CK_TOO_MANY_STEPS;
        int slot = kernel_step(S, t_limit, T, P, &w);
        if (slot == CK_UNDERFLOW || slot == CK_BAD_STATE) return slot;
        if (slot >= 0) {
            *t_switch = S[CK_T];
            checked_output_row(S, fmin(S[CK_T], t_target), T, P, row);
            return 1;
        }
    }
    checked_output_row(S, t_target, T, P, row);
    return 0;
}

int ck_run_chunk(double* S, double t_end, const double* times, int n_times, int* i_out, double* rows,
                 double* step_store, int store_capacity, int* n_store, double* events_out, int event_capacity,
                 int* n_events, double* modes, int mode_capacity, int* n_modes, const CkTables* T, const double* P)
{
    Scratch w;
    while (*i_out < n_times && times[*i_out] <= S[CK_T]) {
        kernel_output_row(S, times[*i_out], T, P, w.work, w.f, rows + (size_t)(*i_out) * CK_OUT_SIZE);
        (*i_out)++;
    }
    while (S[CK_T] < t_end) {
        if (*n_store >= store_capacity || *n_events >= event_capacity || *n_modes >= mode_capacity) return 1;
        int slot = kernel_step(S, t_end, T, P, &w);
        if (slot == CK_UNDERFLOW || slot == CK_BAD_STATE) return slot;
        while (*i_out < n_times && times[*i_out] <= S[CK_T]) {
            kernel_output_row(S, times[*i_out], T, P, w.work, w.f, rows + (size_t)(*i_out) * CK_OUT_SIZE);
            (*i_out)++;
        }
        memcpy(step_store + (size_t)(*n_store) * CK_STATE_SIZE, S, CK_STATE_SIZE * sizeof(double));
        (*n_store)++;
        if (slot >= 0) {
            double* e = events_out + (size_t)(*n_events) * 3;
            e[0] = S[CK_T];
            e[1] = slot;
            e[2] = S[CK_STEP_MOTOR];
            (*n_events)++;
            if (S[CK_MOTOR] != S[CK_STEP_MOTOR] || S[CK_DIRECTION] != S[CK_STEP_DIRECTION]) {
                double* md = modes + (size_t)(*n_modes) * 4;
                md[0] = S[CK_T];
                md[1] = S[CK_MOTOR];
                md[2] = S[CK_DIRECTION];
                md[3] = S[CK_INTERVAL];
                (*n_modes)++;
            }
        }
    }
    return 0;
}

void ck_dense_many(const double* store, int n_store, const double* times, int n_times, double* out)
{
    int last = n_store - 1;
    for (int i = 0; i < n_times; i++) {
        /* the first stored step ending at or after t (numpy's searchsorted, side left) */
        int lo = 0, hi = n_store;
        while (lo < hi) {
            int mid = (lo + hi) / 2;
            if (store[(size_t)mid * CK_STATE_SIZE + CK_T] < times[i]) lo = mid + 1; else hi = mid;
        }
        int k = lo < 1 ? 1 : lo;
        if (k > last) k = last;
        ck_dense(store + (size_t)k * CK_STATE_SIZE, times[i], out + (size_t)i * CK_N_Y);
    }
}

/* lowest and highest omega1 of the last step up to t_end: at the ends, or where the
 * interpolant's slope changes sign between samples (located) */
static void step_extremes(const double* S, double t_end, const CkTables* T, const double* P, double* work,
                          double* tmp, double* g, double* extremes)
{
    ck_dense(S, S[CK_T_PREV], tmp);
    double lowest = tmp[1], highest = tmp[1];
    ck_dense(S, t_end, tmp);
    lowest = fmin(lowest, tmp[1]);
    highest = fmax(highest, tmp[1]);
    double h = S[CK_T] - S[CK_T_PREV];
    if (h > 0.0) {
        double ta = S[CK_T_PREV];
        double da = kernel_omega_slope(S, 0.0);
        for (int i = 1; i <= CK_SLOPE_SAMPLES; i++) {
            double tb = S[CK_T_PREV] + (t_end - S[CK_T_PREV]) * i / CK_SLOPE_SAMPLES;
            double db = kernel_omega_slope(S, (tb - S[CK_T_PREV]) / h);
            if ((da > 0.0 && 0.0 >= db) || (da < 0.0 && 0.0 <= db)) {
                ck_dense(S, kernel_locate(S, -2, 0.0, ta, tb, da, db, T, P, work, tmp, g), tmp);
                lowest = fmin(lowest, tmp[1]);
                highest = fmax(highest, tmp[1]);
            }
            ta = tb;
            da = db;
        }
    }
    extremes[0] = lowest;
    extremes[1] = highest;
}

/* one machine cycle (T->period of crank angle: one turn, or a four-stroke engine's two) from
 * (phi_start, omega_start) at t = 0: stats <- (omega1 at its end, min, max, period). 0, 2 when the
 * crank stops or turns back first (or passes t_max), 3 on underflow. */
static int one_cycle(double* S, double phi_start, double omega_start, double t_max, const CkTables* T,
                    const double* P, Scratch* w, double* stats, double* extremes)
{
    for (int j = 0; j < CK_N_Y; j++) w->y[j] = 0.0;
    w->y[0] = phi_start;
    w->y[1] = omega_start;
    for (int j = 0; j < CK_STATE_SIZE; j++) S[j] = 0.0;
    double y0[CK_N_Y];
    memcpy(y0, w->y, sizeof y0);
    kernel_start(S, 0.0, y0, T, P, w);
    double phi_end = phi_start + T->period;
    double w_min = omega_start, w_max = omega_start;
    for (;;) {
        int slot = kernel_step(S, t_max, T, P, w);
        if (slot == CK_UNDERFLOW || slot == CK_BAD_STATE) return 3;
        int done = S[CK_Y] >= phi_end;
        double t_end = S[CK_T];
        if (done)
            t_end = kernel_locate(S, -1, phi_end, S[CK_T_PREV], S[CK_T], S[CK_Y_PREV] - phi_end, S[CK_Y] - phi_end, T, P,
                           w->work, w->tmp, w->g0);
        step_extremes(S, t_end, T, P, w->work, w->tmp, w->g0, extremes);
        w_min = fmin(w_min, extremes[0]);
        w_max = fmax(w_max, extremes[1]);
        if (done) {
            ck_dense(S, t_end, w->tmp);
            stats[0] = w->tmp[1];
            stats[1] = w_min;
            stats[2] = w_max;
            stats[3] = t_end;
            return 0;
        }
        if (S[CK_Y + 1] <= 0.0 || S[CK_T] >= t_max) return 2;
    }
}

void ck_steady_batch(const double* params, int n_designs, double phi_start, const double* omega_guess,
                     double rtol_shoot, int max_turns, const CkTables* T, double* out)
{
    double S[CK_STATE_SIZE] = {0.0}, stats[4] = {0.0}, extremes[2] = {0.0};
    Scratch w;
    for (int d = 0; d < n_designs; d++) {
        const double* P = params + (size_t)d * CK_PARAM_SIZE;
        double wv = omega_guess[d], w_prev = 0.0, r_prev = 0.0;
        double status = CK_STEADY_NOT_CONVERGED;
        int turns = 0;
        for (int it = 0; it < max_turns; it++) {
            double t_max = 1000.0 * T->period / fmax(fabs(wv), 1e-3);
            int code = one_cycle(S, phi_start, wv, t_max, T, P, &w, stats, extremes);
            turns++;
            if (code == 2) {
                status = CK_STEADY_STALLS;
                break;
            }
            if (code == 3) {
                status = CK_STEADY_UNDERFLOW;
                break;
            }
            double r = stats[0] - wv;
            if (fabs(r) <= rtol_shoot * fabs(wv)) {
                status = CK_STEADY_OK;
                break;
            }
            double w_next;
            if (it == 0 || r == r_prev)
                w_next = stats[0];
            else
                w_next = wv - r * (wv - w_prev) / (r - r_prev);
            if (!(w_next > 0.0)) w_next = 0.5 * wv;
            w_prev = wv;
            r_prev = r;
            wv = w_next;
        }
        double period = stats[3];
        double mean = period > 0.0 ? T->period / period : NAN;
        double* o = out + (size_t)d * CK_STEADY_SIZE;
        o[0] = mean;
        o[1] = stats[1];
        o[2] = stats[2];
        o[3] = (stats[2] - stats[1]) / mean;
        o[4] = period;
        o[5] = turns;
        o[6] = status;
    }
}
