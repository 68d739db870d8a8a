/* The kernel's speed-causal step (crank_kernel.h): the crank speed imposed by a drive, the torque
 * it takes and the works, on the tabulated model (crank_kernel.c). */
#include "crank_kernel_internal.h"

#include <math.h>
#include <string.h>

/* ------------------------------------------------------------------ speed causality
 *
 * The drive imposes omega1 (crank_kernel.h). Over a communication step omega1 is a line in time:
 * from the input at the step's start, with the host's input derivative where it gave one, else
 * with the input's change over the last step (a backward difference: without a slope the
 * mechanism's own inertia J epsilon1 would vanish from the coupling, and the co-simulation would
 * not converge as the step shrinks). phi1 is the line's integral, exact. The works are
 * Gauss-Legendre sums, 5 nodes (exact for polynomials of degree 9) on each piece of at most one
 * degree of crank angle. The pieces end where the powers are not smooth: where the line crosses a
 * switch angle of the slider forces (their value jumps there) and where omega1 changes sign
 * (their side does), so every piece integrates a smooth function. */

/* 5-point Gauss-Legendre on [0, 1]: nodes (1 +- x) / 2, x = sqrt(5 -+ 2 sqrt(10/7)) / 3, and
 * weights (322 +- 13 sqrt(70)) / 1800, from their closed forms */
static void gauss_legendre5(double* nodes, double* weights)
{
    double inner = sqrt(5.0 - 2.0 * sqrt(10.0 / 7.0)) / 3.0, outer = sqrt(5.0 + 2.0 * sqrt(10.0 / 7.0)) / 3.0;
    double w_inner = (322.0 + 13.0 * sqrt(70.0)) / 1800.0, w_outer = (322.0 - 13.0 * sqrt(70.0)) / 1800.0;
    const double x[5] = {-outer, -inner, 0.0, inner, outer};
    const double w[5] = {w_outer, w_inner, 128.0 / 450.0, w_inner, w_outer};
    for (int i = 0; i < 5; i++) {
        nodes[i] = 0.5 * (1.0 + x[i]);
        weights[i] = w[i];
    }
}

/* (J, 0.5 J', Q, tau_e) at an imposed (phi1, omega1) and time t: the slider forces on the side
 * omega1's sign gives (ck_direction_imposed), in the switch interval holding phi1 (Q without the
 * joints' friction, which the imposed acceleration decides: kernel_friction_imposed) */
static void imposed_coefficients(double t, double phi, double omega, const CkTables* T, const double* P,
                                 double* work, double* J, double* half_dJ, double* Q, double* tau)
{
    double direction = ck_direction_imposed(omega), lo, hi;
    int k = ck_interval_of(T->switch_angles, T->m, phi, direction != 0.0 ? direction : 1.0, &lo, &hi);
    kernel_coefficients_free(t, phi, omega, direction, (double)k, T, P, work, J, half_dJ, Q, tau);
}

/* the state's mode and the output row at S's time and state, epsilon1 = S[CK_F + 1] */
static void speed_row(double* S, const CkTables* T, const double* P, double* work, double* row)
{
    double t = S[CK_T], phi = S[CK_Y], omega = S[CK_Y + 1], epsilon = S[CK_F + 1], lo, hi;
    double direction = ck_direction_imposed(omega);
    S[CK_DIRECTION] = direction;
    S[CK_INTERVAL] = (double)ck_interval_of(T->switch_angles, T->m, phi, direction != 0.0 ? direction : 1.0, &lo, &hi);
    S[CK_PHI_LO] = lo;
    S[CK_PHI_HI] = hi;
    double J, half_dJ, Q, tau;
    kernel_coefficients_free(t, phi, omega, direction, S[CK_INTERVAL], T, P, work, &J, &half_dJ, &Q, &tau);
    /* the joints' friction of the imposed motion: the drive takes it too */
    double friction = kernel_friction_imposed(t, phi, omega, epsilon, direction, S[CK_INTERVAL], T, P, NULL);
    for (int j = 0; j < CK_N_Y; j++) row[j] = S[CK_Y + j];
    row[CK_OUT_W_FRICTION] = S[CK_Y + CK_W_FRICTION];
    row[CK_OUT_M_FRICTION] = friction;
    row[5] = epsilon;
    row[6] = ck_drive_torque(J, half_dJ, Q + friction, tau, omega, epsilon);
    row[7] = Q;
    row[8] = J;
    row[9] = tau;
}

void ck_speed_row(double* S, const CkTables* T, const double* P, double* row)
{
    Scratch w;
    speed_row(S, T, P, w.work, row);
}

double ck_speed_slope(const double* S, double omega, double rate, int rate_given)
{
    double last = S[CK_T] - S[CK_T_PREV];
    return rate_given ? rate : (last > 0.0 ? (omega - S[CK_Y_PREV + 1]) / last : 0.0);
}

void ck_speed_begin(double* S, double t, double phi, double omega, const CkTables* T, const double* P, double* row)
{
    Scratch w;
    memset(S, 0, CK_STATE_SIZE * sizeof(double));
    S[CK_T] = S[CK_T_PREV] = t;
    S[CK_Y] = S[CK_Y_PREV] = phi;
    S[CK_Y + 1] = S[CK_Y_PREV + 1] = omega;
    S[CK_F] = omega;
    speed_row(S, T, P, w.work, row);
}

/* phi1 on the step's line at s from its start */
static double line_angle(double phi0, double omega, double slope, double s)
{
    return phi0 + omega * s + 0.5 * slope * s * s;
}

/* the time in [sa, sb] where the line, monotone there, reaches the angle theta: the root of the
 * quadratic (in its cancellation-free form) that lies in the segment, or the nearer to it */
static double line_time(double phi0, double omega, double slope, double theta, double sa, double sb)
{
    double s;
    if (slope == 0.0) {
        s = (theta - phi0) / omega;
    } else {
        double a = 0.5 * slope, b = omega, c = phi0 - theta;
        double q = -0.5 * (b + copysign(sqrt(fmax(b * b - 4.0 * a * c, 0.0)), b));
        double r1 = q / a, r2 = q != 0.0 ? c / q : r1;
        double d1 = fmax(fmax(sa - r1, r1 - sb), 0.0), d2 = fmax(fmax(sa - r2, r2 - sb), 0.0);
        s = d1 <= d2 ? r1 : r2;
    }
    return fmin(fmax(s, sa), sb);
}

/* the works over [sa, sb] of the step from (t, phi0), where the powers are smooth (the slider
 * forces' side and switch interval k hold: the caller found them; the joints' frictions' signs too,
 * their zeros being switch angles): W[0..3] += the drive's, the loads', the external torque's and
 * the joints' friction's (a slide's |N| may kink inside a piece: pieces are at most a degree) */
static void smooth_works(double t, double phi0, double omega, double slope, double sa, double sb, double direction,
                         int k, const CkTables* T, const double* P, const double* nodes, const double* weights,
                         double* work, double* W)
{
    double turned = fabs(line_angle(phi0, omega, slope, sb) - line_angle(phi0, omega, slope, sa));
    double per_piece = CK_TWO_PI / 360.0;
    long pieces = turned > per_piece ? (long)ceil(turned / per_piece) : 1;
    double hp = (sb - sa) / (double)pieces, J, half_dJ, Q, tau;
    for (long p = 0; p < pieces; p++)
        for (int i = 0; i < 5; i++) {
            double s = sa + ((double)p + nodes[i]) * hp, wq = weights[i] * hp;
            double w_s = omega + slope * s, phi = line_angle(phi0, omega, slope, s);
            kernel_coefficients_free(t + s, phi, w_s, direction, (double)k, T, P, work, &J, &half_dJ, &Q, &tau);
            double friction = kernel_friction_imposed(t + s, phi, w_s, slope, direction, (double)k, T, P, NULL);
            W[0] += wq * ck_drive_torque(J, half_dJ, Q + friction, tau, w_s, slope) * w_s;
            W[1] += wq * Q * w_s;
            W[2] += wq * tau * w_s;
            W[3] += wq * friction * w_s;
        }
}

int ck_speed_advance(double* S, double t_target, double omega, double rate, int rate_given, const CkTables* T,
                     const double* P, double* row)
{
    Scratch w;
    double t = S[CK_T], h = t_target - t;
    if (!(h > 0.0) || !isfinite(t_target) || !isfinite(omega) || !isfinite(rate)) return CK_BAD_STATE;
    double slope = ck_speed_slope(S, omega, rate, rate_given);
    double phi0 = S[CK_Y], J, half_dJ, Q, tau;
    double W[4] = {S[CK_Y + 2], S[CK_Y + 3], S[CK_Y + 4], S[CK_Y + CK_W_FRICTION]};
    /* the step's segments where phi1 is monotone: split where omega1 changes sign */
    double s_turn = slope != 0.0 ? -omega / slope : -1.0;
    double ends[3] = {0.0, h, h};
    int segments = s_turn > 0.0 && s_turn < h ? 2 : 1;
    if (segments == 2) ends[1] = s_turn;
    double travel = 0.0;
    for (int g = 0; g < segments; g++)
        travel += fabs(line_angle(phi0, omega, slope, ends[g + 1]) - line_angle(phi0, omega, slope, ends[g]));
    if (!isfinite(travel) || travel > 1e9 * (CK_TWO_PI / 360.0)) return CK_BAD_STATE;    /* a billion degrees */
    if (omega != S[CK_Y + 1]) {
        /* the input differs from the last step's line at this point: the speed jumps, and the
         * drive does the jump's work, 0.5 J (omega1'^2 - omega1^2), J at phi0 */
        imposed_coefficients(t, phi0, omega, T, P, w.work, &J, &half_dJ, &Q, &tau);
        W[0] += ck_kinetic_energy(J, omega) - ck_kinetic_energy(J, S[CK_Y + 1]);
    }
    double nodes[5], weights[5];
    gauss_legendre5(nodes, weights);
    for (int g = 0; g < segments; g++) {
        double sa = ends[g], sb = ends[g + 1];
        double phi_a = line_angle(phi0, omega, slope, sa), phi_b = line_angle(phi0, omega, slope, sb);
        int forward = phi_b >= phi_a;
        /* omega1's sign holds inside the segment: the side of its middle */
        double direction = ck_direction_imposed(omega + slope * 0.5 * (sa + sb)), lo, hi, s_from = sa;
        int k = ck_interval_of(T->switch_angles, T->m, phi_a, forward ? 1.0 : -1.0, &lo, &hi);
        /* each switch angle the segment crosses ends a piece */
        while (T->m > 0 && (forward ? hi < phi_b : lo > phi_b)) {
            double s_cross = fmax(line_time(phi0, omega, slope, forward ? hi : lo, sa, sb), s_from);
            smooth_works(t, phi0, omega, slope, s_from, s_cross, direction, k, T, P, nodes, weights, w.work, W);
            s_from = s_cross;
            k = ck_next_interval(T->switch_angles, T->m, k, &lo, &hi, forward);
        }
        smooth_works(t, phi0, omega, slope, s_from, sb, direction, k, T, P, nodes, weights, w.work, W);
    }
    S[CK_T_PREV] = t;
    S[CK_Y_PREV] = phi0;
    S[CK_Y_PREV + 1] = omega;
    S[CK_T] = t_target;
    S[CK_Y] = line_angle(phi0, omega, slope, h);
    S[CK_Y + 1] = omega + slope * h;
    S[CK_Y + 2] = W[0];
    S[CK_Y + 3] = W[1];
    S[CK_Y + 4] = W[2];
    S[CK_Y + CK_W_FRICTION] = W[3];
    S[CK_F] = S[CK_Y + 1];
    S[CK_F + 1] = slope;
    S[CK_N_STEPS] += 1.0;
    speed_row(S, T, P, w.work, row);
    for (int j = 0; j < CK_OUT_SIZE; j++)
        if (!isfinite(row[j])) return CK_BAD_STATE;
    return 0;
}
