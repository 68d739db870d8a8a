/* What the kernel's files share, and nothing outside them includes: the stepper on the tabulated
 * model (crank_kernel.c) that the drivers (crank_drivers.c), the speed-causal step
 * (crank_speed.c) and Model Exchange (crank_me.c) run. The public interface is crank_kernel.h. */
#ifndef CRANK_KERNEL_INTERNAL_H
#define CRANK_KERNEL_INTERNAL_H

#include "crank_kernel.h"

/* scratch of one call, on the stack */
typedef struct {
    double work[CK_MAX_FUNCTIONS];
    double Kst[CK_N_STAGES + 1][CK_N_Y];
    double ynew[CK_N_Y], tmp[CK_N_Y], f[CK_N_Y], g0[CK_N_SLOTS], g1[CK_N_SLOTS], y[CK_N_Y], f0[CK_N_Y];
} Scratch;

/* the values the joint reactions' terms multiply (ck_reaction_weights) in the mode (direction,
 * interval): 1, epsilon1, omega1^2, omega1, the switched columns' values, the ports' inputs at t */
int kernel_reaction_weights(double t, double omega, double epsilon, double direction, double interval,
                            const CkTables* T, const double* P, double* out);
/* the joints' frictions at one state (crank_friction.c): f into f_out (n_f; may be NULL) and their
 * generalised force sum k_i f_i (N.m) returned, eps0 the frictionless acceleration (rad/s2) and
 * held: the motion does not respond (the motor sliding on its switch, or a drive imposing it); NaN
 * where they do not settle (friction that locks the mechanism). normals (n_f; may be NULL): each
 * slide's normal force N (a pin's: NaN), whose zeros are the kinks of |N| */
double kernel_friction(double t, double phi, double omega, double direction, double interval, const CkTables* T,
                       const double* P, double J, double eps0, int held, double* f_out, double* normals);
/* each slide friction's normal force (N; a pin's NaN) at (t, y) in S's mode, into normals; 1 where
 * some friction is a slide's (0: none, nothing written) */
int kernel_friction_normals(const double* S, double t, const double* y, const CkTables* T, const double* P,
                            double* normals);
/* the frictions f (n_f, into f_out) and their generalised force (returned) at a state of the mode
 * (motor, direction, interval), as the right-hand side solves them */
double kernel_friction_at(double t, double phi, double omega, double motor, double direction, double interval,
                          const CkTables* T, const double* P, double* f_out);
/* kernel_coefficients without the joints' friction (Q the loads' alone) */
void kernel_coefficients_free(double t, double phi, double omega, double direction, double interval,
                              const CkTables* T, const double* P, double* work, double* J, double* half_dJ, double* Q,
                              double* tau);
/* the joints' frictions where the motion (phi1, omega1, epsilon1) is given: a drive imposing it, or a
 * state whose acceleration is known (f into f_out, may be NULL; their generalised force returned;
 * 0 without friction or at rest) */
double kernel_friction_imposed(double t, double phi, double omega, double epsilon, double direction, double interval,
                               const CkTables* T, const double* P, double* f_out);
/* (J, 0.5 J', Q) with the slider forces of the given interval and direction, and the external
 * torque at time t */
void kernel_coefficients(double t, double phi, double omega, double direction, double interval, const CkTables* T,
                         const double* P, double* work, double* J, double* half_dJ, double* Q, double* tau);
/* the crank's acceleration from rest with the slider forces forward (eps[0]) and backward (eps[1]) */
void kernel_rest_accelerations(double t, double phi, double motor, double interval, const CkTables* T,
                               const double* P, double* work, double* f, double* eps);
/* the slider forces' side for a crank at rest (crank_modes.h's rule on those accelerations) */
double kernel_direction_at_rest(double t, double phi, double motor, double interval, const CkTables* T,
                                const double* P, double* work, double* f);
/* the switch interval of phi in the given direction into S */
void kernel_set_interval(double* S, const CkTables* T, double phi, double direction);
/* the discrete state (motor branch, direction, switch interval) of a start or a restart at (S[CK_T], y) */
void kernel_set_mode(double* S, const double* y, const CkTables* T, const double* P, Scratch* w);
/* a start at (t, y): the mode, the first step size */
void kernel_start(double* S, double t, const double* y, const CkTables* T, const double* P, Scratch* w);
/* event functions of S's mode at (t, y) into g; inactive slots get NaN */
void kernel_events(const double* S, double t, const double* y, const CkTables* T, const double* P, double* work,
                   double* g);
/* discrete state after the event in slot at (t, y) (y adjusted onto the surface) */
void kernel_transition(double* S, int slot, double t, double* y, const CkTables* T, const double* P, double* work,
                       double* f);
/* sign-true slope of omega1 (h domega1/dt) at x in [0, 1] of the last step's interpolant */
double kernel_omega_slope(const double* S, double x);
/* time in [lo, hi] of the last step where g changes sign, by Illinois on the dense output */
double kernel_locate(const double* S, int slot, double level, double lo, double hi, double glo, double ghi,
                     const CkTables* T, const double* P, double* work, double* tmp, double* g);
/* whether S's discrete state is one the kernel can have written */
int kernel_mode_ok(const double* S, const CkTables* T);
/* one accepted step, not beyond t_limit, ending on the first event crossed */
int kernel_step(double* S, double t_limit, const CkTables* T, const double* P, Scratch* w);
/* the rest of an output row whose state row[0:6] (y, W_friction in row[5]) at time t is set, in the given mode */
void kernel_complete_row(double t, double motor, double direction, double interval, const CkTables* T,
                         const double* P, double* work, double* f, double* row);
/* the mode (motor, direction, interval) at t in the last step: S's own at its end, the step's
 * inside it (a switch located at the end changed S's); each triple is contiguous in S, in that
 * order (crank_kernel.h) */
static inline const double* kernel_mode_at(const double* S, double t)
{
    return S + (t == S[CK_T] ? CK_MOTOR : CK_STEP_MOTOR);
}
/* the output row at t in the last step */
void kernel_output_row(const double* S, double t, const CkTables* T, const double* P, double* work, double* f,
                       double* row);

#endif
