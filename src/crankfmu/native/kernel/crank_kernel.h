/* crankfmu's kernel: Dormand-Prince 5(4) on the tabulated reduced model, every switch located,
 * with the hybrid rules of crank_modes.h. The one stepper of the fast path: simulate(), the
 * sweeps, the batch of steady cycles, the pythonfmu FMUs (through ctypes) and the native FMU run
 * this code. C99, the C library only (libm).
 *
 * Everything is flat double arrays, so an FMU saves and restores the whole integrator state by
 * copying CK_STATE_SIZE doubles, and a rolled-back step is recomputed bit for bit.
 */
#ifndef CRANK_KERNEL_H
#define CRANK_KERNEL_H

#include "crank_modes.h"
#include "crank_tableau.h"

#include <stddef.h>

/* exported from the Python binding's library; the native FMU compiles the kernel in with
 * -DCK_API= so that its binary exports the FMI functions only */
#ifndef CK_API
#if defined(_WIN32)
#define CK_API __declspec(dllexport)
#else
#define CK_API __attribute__((visibility("default")))
#endif
#endif

/* ---- the state array */
/* y: phi1, omega1, W_motor, W_load, W_ext, and W_friction (the joints' friction's work: 0 without
 * any, and then left out of the error norm, so that a model without friction steps as it did
 * before friction existed, bit for bit) */
enum {
    CK_T = 0, CK_Y = 1, CK_F = 7, CK_H = 13,                        /* t s, y[6], f[6], proposed step s */
    CK_MOTOR = 14, CK_DIRECTION = 15, CK_INTERVAL = 16, CK_PHI_LO = 17, CK_PHI_HI = 18,   /* the mode */
    CK_T_PREV = 19, CK_Y_PREV = 20, CK_K = 26,                      /* last step: start, state, 7x6 stages */
    CK_N_RHS = 68, CK_STEP_MOTOR = 69, CK_STEP_DIRECTION = 70, CK_STEP_INTERVAL = 71, CK_N_STEPS = 72,
    CK_STATE_SIZE = 73,
    CK_N_Y = 6,
    CK_N_PLAIN = 5,                                                 /* the states of a model without friction */
    CK_W_FRICTION = 5
};

/* ---- the parameter array. The inputs (tau_ext on the crank, then one per port: a force's F or a
 * couple's M) are linear in time from CK_T_INPUT: value + rate (t - t_input); a rate is 0 unless
 * a host gave the input's derivative (fmi2SetRealInputDerivatives) */
enum { CK_MAX_PORTS = 8 };
enum { CK_A_ = 0, CK_B_, CK_A_LOW, CK_B_LOW, CK_OMEGA_SWITCH, CK_TAU_EXT, CK_J_FLYWHEEL, CK_RTOL, CK_ATOL, CK_H_MAX,
       CK_T_INPUT, CK_TAU_EXT_RATE, CK_PORT_INPUT, CK_PORT_RATE = CK_PORT_INPUT + CK_MAX_PORTS,
       CK_PARAM_SIZE = CK_PORT_RATE + CK_MAX_PORTS };

/* ---- the output row: phi1, omega1, W_motor, W_load, W_ext, epsilon1, M_motor, M_load, J_red,
 * tau_e (the external torque on the crank: tau_ext and the ports', what W_ext integrates times omega1),
 * W_friction and M_friction (the joints' friction's work, and its generalised force on the crank:
 * 0 without friction) */
enum { CK_OUT_SIZE = 12, CK_OUT_W_FRICTION = 10, CK_OUT_M_FRICTION = 11 };

/* ---- steady cycles: omega1_mean, omega1_min, omega1_max, delta, period, turns, status */
enum { CK_SLOPE_SAMPLES = 8, CK_STEADY_SIZE = 7 };
#define CK_STEADY_OK 0.0
#define CK_STEADY_NOT_CONVERGED 1.0
#define CK_STEADY_STALLS 2.0
#define CK_STEADY_UNDERFLOW 3.0

/* what the stepping functions return besides an event slot; CK_TOO_MANY_STEPS: one call of
 * ck_advance (an FMU's communication step) would take over CK_MAX_STEPS_PER_CALL steps, which no
 * sensible input does (a host's torque ramp of 1e10 N.m/s spins the crank at 1e9 rad/s): refused
 * so that a host's step ends in seconds, not hours */
enum { CK_NO_EVENT = -1, CK_UNDERFLOW = -2, CK_BAD_STATE = -3, CK_NO_FIXED_POINT = -4, CK_TOO_MANY_STEPS = -5 };
#ifndef CK_MAX_STEPS_PER_CALL           /* (the FMI fuzzer builds with a smaller one, to reach it often) */
#define CK_MAX_STEPS_PER_CALL 10000000L
#endif

/* the largest number of tabulated functions (J, 0.5 J', Q, dQ/domega, one per slider force and
 * one per port) */
enum { CK_MAX_FUNCTIONS = 64 };

/* The tables of one design (dynamics/tabulated.py): n_functions periodic cubics on n intervals of
 * the machine's cycle (period rad: 2 pi times its cycle_turns, a four-stroke engine's 4 pi),
 * coefficients[f][i][4] (c0 + u (c1 + u (c2 + u c3)), u from the interval's left end);
 * the m switch angles (rad, in [0, 2 pi), ascending); the slider forces' factors
 * forces[k][direction 0 forward, 1 backward][n_sliders] of each switch interval. The last n_ports
 * functions are the ports' transfer functions (ds/dphi1 of a force's point along its axis, or
 * dangle/dphi1 of a couple's link): a port's input times its transfer function is a torque on the
 * crank, whose power is accounted in W_ext. A switched column may be a load's part in omega1 or
 * omega1^2 (a fan's -c omega1 |omega1|: columns per power, the direction's sign its value): powers[s]
 * is the power of omega1 its value is multiplied by (0, 1 or 2; NULL: every column 0), or CK_LAW: a
 * general law of the speed (dynamics/speed_laws.py), the column times law(law_context, s, omega1),
 * in either direction and at rest (the forces are not read). */
enum { CK_LAW = 3 };
typedef double (*CkLaw)(const void* context, int column, double omega);
/* Joint friction (dynamics/friction.py; its table: dynamics/tabulated.py, FrictionTable): n_f
 * Coulomb frictions f_i = -c_i s_i |R_i| in joints, c_i = mu r (a pin, |R| the reaction's magnitude)
 * or mu (a slide, |N| its normal force), s_i the sign of the joint's relative rate k_i times
 * omega1's: signs[interval][i] on each switch interval forward (the zeros of the k_i are switch
 * angles), the opposite backward. coefficients: n_f + (sum of components) x (n_terms + n_f)
 * periodic cubics on n intervals of the tables' period, interval-major ([interval][function][4]: the
 * functions a state reads are contiguous): the rates k_i (rad/rad or m/rad), then each
 * friction's reaction components (a pin's two, a slide's normal force) as ck_reaction_weights'
 * n_terms terms followed by one term per unit friction. The movement equation gains sum k_i f_i,
 * and the reactions depend on the acceleration and the frictions: each right-hand side solves for
 * them together by Newton's method (a few iterations). */
enum { CK_MAX_FRICTIONS = 16, CK_MAX_FRICTION_FUNCTIONS = 4096 };
typedef struct {
    int n_f, n_terms;
    const double* coefficients;
    int n;
    const int* components;           /* n_f: 2 (a pin) or 1 (a slide) */
    const double* c;                 /* n_f: mu r (m) or mu */
    const double* signs;             /* max(m, 1) x n_f */
} CkFriction;

typedef struct {
    const double* coefficients;
    int n_functions, n;
    const double* switch_angles;
    int m;
    const double* forces;
    int n_sliders;
    int n_ports;
    double period;
    const int* powers;
    CkLaw law;                       /* g(omega1) of the columns of power CK_LAW (NULL: none has one) */
    const void* law_context;
    const CkFriction* friction;      /* the joints' friction (NULL: none) */
} CkTables;

/* whether something switches at angles or at rest: slider forces (switched columns) or friction */
static inline int ck_switched(const CkTables* T) { return T->n_sliders > 0 || T->friction != NULL; }

/* omega1 to column s's power (1 where it has none), or its law at omega1 (NaN without one: the
 * step is then refused as not finite) */
static inline double ck_column_speed(const CkTables* T, int s, double omega)
{
    int p = T->powers ? T->powers[s] : 0;
    if (p == CK_LAW) return T->law ? T->law(T->law_context, s, omega) : (double)NAN;
    return p == 0 ? 1.0 : (p == 1 ? omega : omega * omega);
}

/* what a stepping function's refusal (CK_UNDERFLOW, CK_TOO_MANY_STEPS, CK_BAD_STATE) says, as every
 * FMU and the fast path word it: one home for the wording ("%s at t = ... s") */
CK_API const char* ck_status_text(int status);

/* the hash of the sources this library was compiled from (sources.py computes the same) */
CK_API const char* ck_source_digest(void);

/* the tableau as numbers: A (6x5), B (6), E (7), P (7x4), C (6) into out; returns the count */
CK_API int ck_tableau(double* out, int n);

/* one hybrid rule of crank_modes.h by number, on up to 10 arguments (the engine's Python rules,
 * dynamics/modes.py, are compared with these rule by rule) */
CK_API double ck_rule(int rule, const double* a);
/* the switch-interval rules: k, and bounds[0:2] = (phi_lo, phi_hi) (in and out for the next) */
CK_API int ck_interval_of_rule(const double* sw, int m, double phi, double direction, double* bounds);
CK_API int ck_next_interval_rule(const double* sw, int m, int k, double* bounds, int forward);

/* the layout as numbers, for callers that check theirs: fills out[0..n) and returns the count */
CK_API int ck_layout(int* out, int n);

/* n_functions periodic cubics on n intervals of period rad (the layout of CkTables.coefficients)
 * at phi into out[0:n_functions] */
CK_API void ck_periodic_cubics(const double* coefficients, int n_functions, int n, double period, double phi,
                               double* out);

/* the values the joint reactions' tabulated terms multiply (dynamics/reaction_table.py, ReactionTable),
 * into out: 1, epsilon1, omega1^2, omega1, each switched load's value in the mode at t (the
 * tables' forces of its interval and direction, 0 at rest; t within S's last step or at its end),
 * each port's input at t; returns the count */
CK_API int ck_reaction_weights(const double* S, double t, double omega, double epsilon, const CkTables* tables,
                               const double* P, double* out);

/* the outputs a host reads besides the state, from their tables, as every FMU computes them (the
 * native FMU's shell and the Python FMU through ctypes): one home for the two rules.
 * Quantities ([[outputs]], the ports' s, v, a; dynamics/tabulated.py, QuantityTable): each of the
 * n_coordinates coordinates tabulated as q - winding phi1, q', q'' (3 n_coordinates cubics on n
 * intervals); quantity k reads coordinate[k] and is of order[k]: q (0), q' omega1 (1) or
 * q'' omega1^2 + q' epsilon1 (2), as mechanisms/quantities.py states them. scratch: 3 n_coordinates. */
CK_API void ck_quantity_values(const double* coefficients, int n_coordinates, int n, const double* winding,
                               int n_quantities, const int* coordinate, const int* order, double phi, double omega,
                               double epsilon, double* scratch, double* out);
/* Joint reactions (ReactionTable): each of n_reactions components is the sum of its n_terms
 * tabulated terms at phi times ck_reaction_weights' values at t (Newton-Euler's linear
 * combination). scratch: n_reactions n_terms + n_terms. Returns 0, or -1 when the table's
 * n_terms is not the kernel's count of weights for these tables. */
CK_API int ck_reaction_values(const double* coefficients, int n_reactions, int n_terms, int n, const double* S,
                              double t, double phi, double omega, double epsilon, const CkTables* tables,
                              const double* P, double* scratch, double* out);

/* the frictions f_i (N.m or N) at t within S's last step (or at its end) with the state y there
 * (ck_dense) and the crank's acceleration epsilon (rad/s2, the output row's), in that step's mode,
 * into out[0:n_f], and their generalised force on the crank (sum k_i f_i, N.m) into out[n_f];
 * returns n_f (0 without friction) or CK_BAD_STATE. The motion given, the frictions are those that
 * move the reactions alone: what the movement equation solved them to, whichever causality */
CK_API int ck_friction_values(const double* S, double t, const double* y, double epsilon, const CkTables* tables,
                              const double* P, double* out);

CK_API void ck_begin(double* S, double t, const double* y, const CkTables* tables, const double* P, double* row);
CK_API int ck_advance(double* S, double t_target, double t_limit, const CkTables* tables, const double* P,
                      double* row);
/* ck_advance, stopping at the first switch it locates (a host that handles events: FMI 3's event
 * mode and early return): returns 1 with *t_switch the switch's time, where the kernel's last step
 * ends and the mode has changed, the output row at the earlier of it and t_target; 0 when t_target
 * was reached with no switch on the way; or ck_advance's refusal */
CK_API int ck_advance_to_switch(double* S, double t_target, double t_limit, const CkTables* tables, const double* P,
                                double* row, double* t_switch);
CK_API void ck_dense(const double* S, double t, double* out);
/* S positioned at t within its last step (or at its end) into out: y there by the dense output, the
 * mode of that step, out[CK_T] = t (what the output row at t is evaluated on: the native FMU's
 * outputs and derivatives at a communication point the kernel stepped past) */
CK_API void ck_point(const double* S, double t, double* out);
CK_API int ck_run_chunk(double* S, double t_end, const double* times, int n_times, int* i_out, double* rows,
                        double* step_store, int store_capacity, int* n_store, double* events, int event_capacity,
                        int* n_events, double* modes, int mode_capacity, int* n_modes, const CkTables* tables,
                        const double* P);
CK_API void ck_dense_many(const double* store, int n_store, const double* times, int n_times, double* out);
CK_API void ck_steady_batch(const double* params, int n_designs, double phi_start, const double* omega_guess,
                            double rtol_shoot, int max_turns, const CkTables* tables, double* out);

/* ---- speed causality: the drive imposes omega1 (an input), the kernel answers with the torque it
 * takes, tau_drive = J epsilon1 + 0.5 J' omega1^2 - Q - tau_e, and integrates phi1 and the works.
 * The same state array, other slots in use: S[CK_T] the time, S[CK_Y..] (phi1, omega1, W_drive,
 * W_load, W_ext), S[CK_F + 1] omega1's slope over the last step (epsilon1), S[CK_T_PREV] and
 * S[CK_Y_PREV + 1] the last step's start and the input omega1 there, S[CK_DIRECTION],
 * S[CK_INTERVAL] the slider forces' side and switch interval now (what ck_reaction_weights reads).
 * The output row has the torque-causal layout with the drive in the motor's place: W_motor is
 * W_drive and M_motor is tau_drive. P holds the flywheel and the ports' inputs (its motor line
 * and tau_ext are not read: tau_ext must be 0). */
/* the start at (t, phi1, omega1), at rest in acceleration */
CK_API void ck_speed_begin(double* S, double t, double phi, double omega, const CkTables* tables, const double* P,
                           double* row);
/* the output row at S's time, phi1 S[CK_Y], omega1 S[CK_Y + 1] and epsilon1 S[CK_F + 1] (the works
 * S[CK_Y + 2..]), S's mode set there: what a step ending there gives (the native FMU reads its
 * outputs at an input just set, and its derivatives, through it) */
CK_API void ck_speed_row(double* S, const CkTables* tables, const double* P, double* row);
/* omega1's slope over the step from S's time with the input omega1 there: the host's derivative
 * (rate) where rate_given, else the input's change since the last step's start over that step */
CK_API double ck_speed_slope(const double* S, double omega, double rate, int rate_given);
/* one communication step to t_target with the input omega1 at its start; rate_given: the input's
 * derivative is rate (1/s2), else omega1's slope is the input's change over the last step. 0, or
 * CK_BAD_STATE (a step not forward, non-finite values, or more than 1e9 degrees in one step) */
CK_API int ck_speed_advance(double* S, double t_target, double omega, double rate, int rate_given,
                            const CkTables* tables, const double* P, double* row);

/* ---- Model Exchange (the native FMU): the host integrates y = (phi1, omega1, W_motor, W_load,
 * W_ext); S holds the mode (CK_MOTOR .. CK_PHI_HI) */
/* the mode of a start or restart at y */
CK_API void ck_me_mode(double* S, const double* y, const CkTables* tables, const double* P);
/* dy/dt in S's mode into dydt, and the output row into row (either may be NULL); 0 or CK_BAD_STATE */
CK_API int ck_me_derivatives(const double* S, const double* y, const CkTables* tables, const double* P,
                             double* dydt, double* row);
/* the CK_N_SLOTS event indicators, with hysteresis (never 0 right after ck_me_update); 0 or CK_BAD_STATE */
CK_API int ck_me_indicators(const double* S, const double* y, const CkTables* tables, const double* P, double* z);
/* event mode: every transition whose surface y is across, y put on the surface; returns how many
 * (0: nothing changed), CK_BAD_STATE, or CK_NO_FIXED_POINT when the transitions do not settle */
CK_API int ck_me_update(double* S, double* y, const CkTables* tables, const double* P);

#endif
