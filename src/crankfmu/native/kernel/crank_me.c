/* The kernel's Model Exchange (crank_kernel.h): the derivatives, event indicators and mode updates
 * a host's integrator calls, on the stepper's rules (crank_kernel.c). */
#include "crank_kernel_internal.h"

#include <math.h>
#include <string.h>

/* ------------------------------------------------------------------ Model Exchange
 *
 * The same model for a host's integrator: S holds the discrete state (the mode) only, the host
 * holds y. A mode ends where the Co-Simulation step would locate an event; the host finds the
 * crossing of an event indicator, and ck_me_update applies the kernel's own transitions there.
 *
 * Hysteresis: a transition puts the state on the switching surface (kernel_transition() projects it,
 * as the Co-Simulation step does), where the surface that would undo it has g = 0 exactly. Each
 * indicator is therefore g moved by a small band towards the side where its mode lives, so no
 * indicator is zero after event mode, and a mode ends once g is across by the band (ck_me_update
 * accepts half of it, so a crossing the host located a little early still counts). The band is
 * CK_HYSTERESIS relative to the surface's own scale: far below any tolerance a host can ask of
 * its integrator, so it does not show in the results. */

#define CK_HYSTERESIS 1e-10

static double band(int slot, const double* S, const double* P)
{
    if (slot == CK_INTERVAL_END || slot == CK_INTERVAL_START)
        return CK_HYSTERESIS * (1.0 + fmax(fabs(S[CK_PHI_LO]), fabs(S[CK_PHI_HI])));
    if (slot == CK_REST) return CK_HYSTERESIS * (1.0 + fabs(P[CK_OMEGA_SWITCH]));
    if (S[CK_MOTOR] == CK_SLIDE || slot == CK_SLIDE_HIGH)           /* torques, N.m */
        return CK_HYSTERESIS * (1.0 + fabs(P[CK_A_]) + fabs(P[CK_A_LOW]));
    return CK_HYSTERESIS * (1.0 + fabs(P[CK_OMEGA_SWITCH]));
}

void ck_me_mode(double* S, const double* y, const CkTables* T, const double* P)
{
    Scratch w;
    kernel_set_mode(S, y, T, P, &w);
}

int ck_me_derivatives(const double* S, const double* y, const CkTables* T, const double* P, double* dydt,
                      double* row)
{
    Scratch w;
    double own[CK_OUT_SIZE];
    if (!kernel_mode_ok(S, T)) return CK_BAD_STATE;
    if (!row) row = own;
    for (int j = 0; j < CK_N_Y; j++) row[j] = y[j];
    kernel_complete_row(S[CK_T], S[CK_MOTOR], S[CK_DIRECTION], S[CK_INTERVAL], T, P, w.work, w.f, row);
    if (dydt)
        for (int j = 0; j < CK_N_Y; j++) dydt[j] = w.f[j];
    return 0;
}

/* stuck at rest: max(eps forward, -eps backward) > 0 once the crank would move (an input or a
 * parameter changed); a surface the Co-Simulation step needs not, as it restarts on any change */
static double unstick_value(const double* S, const double* y, const CkTables* T, const double* P, Scratch* w)
{
    double eps[2];
    kernel_rest_accelerations(S[CK_T], y[0], S[CK_MOTOR], S[CK_INTERVAL], T, P, w->work, w->f, eps);
    return fmax(eps[0], -eps[1]);
}

int ck_me_indicators(const double* S, const double* y, const CkTables* T, const double* P, double* z)
{
    Scratch w;
    if (!kernel_mode_ok(S, T)) return CK_BAD_STATE;
    kernel_events(S, S[CK_T], y, T, P, w.work, w.g0);
    for (int slot = 0; slot < CK_N_SLOTS; slot++) {
        double g = w.g0[slot];
        if (!isfinite(g)) {
            z[slot] = 1.0;             /* inactive in this mode: a constant, never crossed */
            continue;
        }
        double b = band(slot, S, P);
        z[slot] = ck_event_rising(slot, S[CK_MOTOR], S[CK_DIRECTION]) ? g - b : g + b;
    }
    if (S[CK_DIRECTION] == 0.0 && ck_switched(T))
        z[CK_REST] = unstick_value(S, y, T, P, &w) - CK_HYSTERESIS;
    return 0;
}

int ck_me_update(double* S, double* y, const CkTables* T, const double* P)
{
    Scratch w;
    if (!kernel_mode_ok(S, T)) return CK_BAD_STATE;
    int transitions = 0;
    for (int round = 0; round < 4 * CK_N_SLOTS; round++) {
        if (S[CK_DIRECTION] == 0.0) {
            if (!ck_switched(T)) return transitions;
            double direction = kernel_direction_at_rest(S[CK_T], y[0], S[CK_MOTOR], S[CK_INTERVAL], T, P, w.work, w.f);
            if (direction == 0.0) return transitions;
            S[CK_DIRECTION] = direction;
            kernel_set_interval(S, T, y[0], direction);
            transitions++;
            continue;
        }
        kernel_events(S, S[CK_T], y, T, P, w.work, w.g0);
        int ended = -1;
        for (int slot = 0; slot < CK_N_SLOTS && ended < 0; slot++) {
            double g = w.g0[slot], half = 0.5 * band(slot, S, P);
            if (!isfinite(g)) continue;
            if (ck_event_rising(slot, S[CK_MOTOR], S[CK_DIRECTION]) ? g >= half : g <= -half) ended = slot;
        }
        if (ended < 0) return transitions;
        kernel_transition(S, ended, S[CK_T], y, T, P, w.work, w.f);
        transitions++;
    }
    return CK_NO_FIXED_POINT;
}
