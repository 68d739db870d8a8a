/* The movement equation's hybrid rules, as small scalar functions (the C side of
 * dynamics/modes.py, which the scipy engine runs: tests/test_modes.py compares the two
 * rule by rule).
 *
 * The right-hand side is smooth within a mode, the discrete state an integrator holds fixed during
 * a step: the motor branch (LOW, HIGH, or SLIDE on a jump of the motor line), the direction of
 * the slider forces (+1, -1, or 0: stuck at rest) and the switch interval k of the slider forces
 * with its unwrapped angle bounds. What ends a mode is the crossing of a switching surface, an
 * event slot (MOTOR_SWITCH, SLIDE_HIGH, INTERVAL_END, INTERVAL_START, REST).
 */
#ifndef CRANK_MODES_H
#define CRANK_MODES_H

#include <math.h>

#define CK_TWO_PI (2.0 * 3.141592653589793)

/* motor branches (floats: what the state array holds) */
#define CK_LOW 0.0
#define CK_HIGH 1.0
#define CK_SLIDE 2.0

/* event slots */
enum { CK_MOTOR_SWITCH = 0, CK_SLIDE_HIGH = 1, CK_INTERVAL_END = 2, CK_INTERVAL_START = 3, CK_REST = 4,
       CK_N_SLOTS = 5 };

/* torque (N.m) of one motor line at omega1: A - B omega1, extended past its range */
static inline double ck_line_torque(double A, double B, double omega) { return A - B * omega; }

/* domega1/dt from J domega1/dt + 0.5 J' omega1^2 = M_motor + Q + tau_ext */
static inline double ck_acceleration(double J, double half_dJ, double Q, double M, double tau, double omega)
{
    return (M + Q + tau - half_dJ * omega * omega) / J;
}

/* the motor torque that holds domega1/dt = 0: what the motor delivers while sliding */
static inline double ck_equivalent_torque(double half_dJ, double Q, double tau, double omega)
{
    return half_dJ * omega * omega - Q - tau;
}

/* the torque a drive applies to impose omega1 and epsilon1 (speed causality, inverse dynamics) */
static inline double ck_drive_torque(double J, double half_dJ, double Q, double tau, double omega, double epsilon)
{
    return J * epsilon + half_dJ * omega * omega - Q - tau;
}

static inline double ck_kinetic_energy(double J, double omega) { return 0.5 * J * (omega * omega); }

/* the motor branch off the switch: high above omega_switch, low at or below it */
static inline double ck_motor_of_speed(double omega, double omega_switch)
{
    return omega > omega_switch ? CK_HIGH : CK_LOW;
}

/* the slider forces' side for a moving crank (forward at rest until ck_direction_at_rest) */
static inline double ck_direction_of_speed(double omega) { return omega < 0.0 ? -1.0 : 1.0; }

/* the slider forces' side where the drive imposes omega1 (speed causality): omega1's sign, none at
 * rest (the crank held still by the drive feels no Coulomb force) */
static inline double ck_direction_imposed(double omega) { return omega > 0.0 ? 1.0 : (omega < 0.0 ? -1.0 : 0.0); }

/* a switched column's factor on the side ``direction``, from its values forward and backward on
 * the interval: at rest (0) the value where the two agree (a load that does not depend on the
 * direction: a contact, a kink of the position, a law of the speed), else none (a Coulomb force or a
 * working stroke's, whose value at rest the mode decides) */
static inline double ck_column_factor(double forward, double backward, double direction)
{
    if (direction > 0.0) return forward;
    if (direction < 0.0) return backward;
    return forward == backward ? forward : 0.0;
}

/* Filippov's rule on omega1 = omega_switch: m_low, m_high the lines' torques there, rest the
 * acceleration term without the motor. A line that jumps down traps the speed: SLIDE. */
static inline double ck_motor_on_switch(double m_low, double m_high, double rest)
{
    int up_low = m_low + rest > 0.0;
    int up_high = m_high + rest > 0.0;
    if (up_low && up_high) return CK_HIGH;
    if (!up_low && !up_high) return CK_LOW;
    if (up_low && !up_high) return CK_SLIDE;
    return CK_HIGH;
}

/* side of the slider forces from rest: the way the crank accelerates with that side's forces, or
 * 0: stuck */
static inline double ck_direction_at_rest(double eps_forward, double eps_backward)
{
    if (eps_forward > 0.0) return 1.0;
    if (eps_backward < 0.0) return -1.0;
    return 0.0;
}

/* motor branch once the crank comes to rest: the low line, unless sliding */
static inline double ck_motor_at_rest(double motor, double omega_switch)
{
    if (motor != CK_SLIDE && omega_switch > 0.0) return CK_LOW;
    return motor;
}

/* branch after sliding ends: the low line gave up (MOTOR_SWITCH) or the high one suffices */
static inline double ck_motor_after_sliding(int slot) { return slot == CK_MOTOR_SWITCH ? CK_LOW : CK_HIGH; }

/* whether the event in slot puts the crank at rest where the slider forces change side */
static inline int ck_turns_forces(int slot, double omega_switch, int has_sliders)
{
    if (slot == CK_REST) return 1;
    return slot <= CK_SLIDE_HIGH && omega_switch == 0.0 && has_sliders;
}

/* angle from switch angle k to the next one round the turn */
static inline double ck_interval_width(const double* sw, int m, int k)
{
    double end = k + 1 < m ? sw[k + 1] : sw[0] + CK_TWO_PI;
    return end - sw[k];
}

/* the switch interval holding phi (unwrapped) and its unwrapped bounds; on a switch angle the
 * interval the motion enters wins. No switch angles: (0, -inf, inf). */
static inline int ck_interval_of(const double* sw, int m, double phi, double direction, double* lo, double* hi)
{
    if (m == 0) {
        *lo = -INFINITY;
        *hi = INFINITY;
        return 0;
    }
    double wrapped = phi - CK_TWO_PI * floor(phi / CK_TWO_PI);
    int k = m - 1;
    for (int i = 0; i < m; i++)
        if (sw[i] <= wrapped) k = i;
    if (direction < 0.0 && wrapped == sw[k]) k = ((k - 1) % m + m) % m;
    double offset = wrapped - sw[k];
    if (offset < 0.0) offset += CK_TWO_PI;
    *lo = phi - offset;
    *hi = phi - offset + ck_interval_width(sw, m, k);
    return k;
}

/* the neighbouring interval, by counting */
static inline int ck_next_interval(const double* sw, int m, int k, double* lo, double* hi, int forward)
{
    if (forward) {
        k = (k + 1) % m;
        *lo = *hi;
        *hi = *hi + ck_interval_width(sw, m, k);
        return k;
    }
    k = ((k - 1) % m + m) % m;
    *hi = *lo;
    *lo = *lo - ck_interval_width(sw, m, k);
    return k;
}

/* whether surface slot can end a mode (stuck: nothing changes until a restart) */
static inline int ck_event_active(int slot, double motor, double direction, double phi_hi, int has_sliders,
                                  double omega_switch)
{
    if (direction == 0.0) return 0;
    if (slot == CK_MOTOR_SWITCH) return 1;
    if (slot == CK_SLIDE_HIGH) return motor == CK_SLIDE;
    if (slot == CK_REST) return has_sliders && omega_switch != 0.0;
    return isfinite(phi_hi);
}

/* g of surface slot at (phi1, omega1) */
static inline double ck_event_value(int slot, double phi, double omega, double motor, double phi_lo, double phi_hi,
                                    double omega_switch, double m_low, double m_high, double equivalent)
{
    if (slot == CK_MOTOR_SWITCH) {
        if (motor == CK_SLIDE) return m_low - equivalent;
        return omega - omega_switch;
    }
    if (slot == CK_SLIDE_HIGH) return equivalent - m_high;
    if (slot == CK_INTERVAL_END) return phi - phi_hi;
    if (slot == CK_INTERVAL_START) return phi - phi_lo;
    return omega;
}

/* whether surface slot ends the mode when g rises through 0 (else when it falls) */
static inline int ck_event_rising(int slot, double motor, double direction)
{
    if (slot == CK_MOTOR_SWITCH) return motor == CK_LOW;
    if (slot == CK_INTERVAL_END) return 1;
    if (slot == CK_REST) return direction < 0.0;
    return 0;
}

/* whether g went from g0 to g1 through 0 the way that ends the mode */
static inline int ck_crosses(double g0, double g1, int rising)
{
    if (!(isfinite(g0) && isfinite(g1))) return 0;
    if (rising) return g0 < 0.0 && 0.0 <= g1;
    return g0 > 0.0 && 0.0 >= g1;
}

#endif
