/* The C RK4 limit of issue 17: seed 000's four-bar written out by hand in C (the same right-hand
 * side as end_to_end.fourbar_rhs), classical RK4 at a fixed step, the motor kink located.
 *
 * What a hand-coded special-purpose integrator costs for this one mechanism: no data files, no
 * model build, no table, no error control. end_to_end.c_rk4_limit compiles it, runs it at finer
 * steps until it reaches the target error, and reports its time beside simulate()'s.
 *
 * usage: c_rk4 l0 l1 l2 l3 q1 q2 q3 Mr J_F A B A_low B_low omega_switch phi0 omega0 t_end dt_out
 *        substeps repeats
 * prints the fastest of `repeats` runs in seconds, then omega1 at every output time after t = 0.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double l0, l1, l2, l3, m1, m2, m3, I1, I2, I3, Mr, J_F, A, B, A_low, B_low, ws, phi1d, phi1a;

static double rocker_angle(double r) { return acos((r * r + l0 * l0 - l3 * l3) / (2 * l0 * r)); }

/* domega/dt on the start-up line (high = 0) or the working line (high = 1) */
static double accel(double phi1, double w, int high) {
    double s1 = sin(phi1), c1 = cos(phi1);
    double ax = l1 * c1, ay = l1 * s1, dx = l0 - ax, dy = -ay;
    double d = hypot(dx, dy), alpha = atan2(dy, dx);
    double beta = acos((l2 * l2 + d * d - l3 * l3) / (2 * l2 * d));
    double phi2 = alpha + beta;
    double bx = ax + l2 * cos(phi2), by = ay + l2 * sin(phi2);
    double phi3 = atan2(-by, l0 - bx);
    double s2 = sin(phi2), c2 = cos(phi2), s3 = sin(phi3), c3 = cos(phi3);
    double det = l2 * l3 * (-s2 * c3 + c2 * s3);
    double rx = l1 * s1, ry = -l1 * c1;
    double q2 = (rx * l3 * c3 + l3 * s3 * ry) / det, q3 = (-l2 * s2 * ry - l2 * c2 * rx) / det;
    double rx2 = l1 * c1 + l2 * c2 * q2 * q2 + l3 * c3 * q3 * q3;
    double ry2 = l1 * s1 + l2 * s2 * q2 * q2 + l3 * s3 * q3 * q3;
    double qq2 = (rx2 * l3 * c3 + l3 * s3 * ry2) / det, qq3 = (-l2 * s2 * ry2 - l2 * c2 * rx2) / det;
    double t1 = -0.5 * l1 * s1, p1 = 0.5 * l1 * c1, tt1 = -0.5 * l1 * c1, pp1 = -0.5 * l1 * s1;
    double t2 = -l1 * s1 - 0.5 * l2 * s2 * q2, p2 = l1 * c1 + 0.5 * l2 * c2 * q2;
    double tt2 = -l1 * c1 - 0.5 * l2 * (c2 * q2 * q2 + s2 * qq2);
    double pp2 = -l1 * s1 + 0.5 * l2 * (-s2 * q2 * q2 + c2 * qq2);
    double t3 = 0.5 * l3 * s3 * q3, p3 = -0.5 * l3 * c3 * q3;
    double tt3 = 0.5 * l3 * (c3 * q3 * q3 + s3 * qq3), pp3 = 0.5 * l3 * (s3 * q3 * q3 - c3 * qq3);
    double J = J_F + m1 * (t1 * t1 + p1 * p1) + I1 + m2 * (t2 * t2 + p2 * p2) + I2 * q2 * q2
               + m3 * (t3 * t3 + p3 * p3) + I3 * q3 * q3;
    double half_dJ = m1 * (t1 * tt1 + p1 * pp1) + m2 * (t2 * tt2 + p2 * pp2) + I2 * q2 * qq2
                     + m3 * (t3 * tt3 + p3 * pp3) + I3 * q3 * qq3;
    double Q = Mr * sin(0.5 * (phi1 - phi1d)) * sin(0.5 * (phi1 - phi1a)) * q3;
    double M = high ? A - B * w : A_low - B_low * w;
    return (M + Q - half_dJ * w * w) / J;
}

static void rk4(double *phi, double *w, double h, int high) {
    double k1p = *w, k1w = accel(*phi, *w, high);
    double k2p = *w + 0.5 * h * k1w, k2w = accel(*phi + 0.5 * h * k1p, k2p, high);
    double k3p = *w + 0.5 * h * k2w, k3w = accel(*phi + 0.5 * h * k2p, k3p, high);
    double k4p = *w + h * k3w, k4w = accel(*phi + h * k3p, k4p, high);
    *phi += h / 6 * (k1p + 2 * k2p + 2 * k3p + k4p);
    *w += h / 6 * (k1w + 2 * k2w + 2 * k3w + k4w);
}

/* one run: omega1 at each output time into out[]; the kink (omega1 rising through ws) located by
 * the secant method on the length of the RK4 step that ends on it */
static void run(double phi0, double w0, int n_out, double dt_out, int sub, double *out) {
    double phi = phi0, w = w0, h = dt_out / sub;
    int high = w0 >= ws;
    for (int i = 0; i < n_out; i++) {
        for (int k = 0; k < sub; k++) {
            double p_old = phi, w_old = w;
            rk4(&phi, &w, h, high);
            if (!high && w >= ws) {
                double a = 0, fa = w_old - ws, b = h, fb = w - ws;
                for (int it = 0; it < 60 && fabs(b - a) > 1e-15; it++) {
                    double c = b - fb * (b - a) / (fb - fa), pc = p_old, wc = w_old;
                    rk4(&pc, &wc, c, 0);
                    a = b, fa = fb, b = c, fb = wc - ws;
                    if (fb == 0) break;
                }
                phi = p_old, w = w_old;
                rk4(&phi, &w, b, 0);          /* to the kink on the start-up line */
                w = ws, high = 1;
                rk4(&phi, &w, h - b, 1);      /* the rest of the step on the working line */
            }
        }
        out[i] = w;
    }
}

int main(int argc, char **argv) {
    if (argc != 21) {
        fprintf(stderr, "usage: c_rk4 l0 l1 l2 l3 q1 q2 q3 Mr J_F A B A_low B_low omega_switch phi0 omega0 "
                        "t_end dt_out substeps repeats\n");
        return 2;
    }
    double v[20];
    for (int i = 1; i < 21; i++) v[i - 1] = atof(argv[i]);
    l0 = v[0], l1 = v[1], l2 = v[2], l3 = v[3];
    m1 = v[4] * l1, m2 = v[5] * l2, m3 = v[6] * l3;
    I1 = m1 * l1 * l1 / 12, I2 = m2 * l2 * l2 / 12, I3 = m3 * l3 * l3 / 12;
    Mr = v[7], J_F = v[8], A = v[9], B = v[10], A_low = v[11], B_low = v[12], ws = v[13];
    phi1d = rocker_angle(l1 + l2), phi1a = rocker_angle(l2 - l1) + M_PI;
    int n_out = (int)lround(v[16] / v[17]), sub = (int)v[18], repeats = (int)v[19];
    double *out = malloc(sizeof(double) * n_out), best = 1e300;
    for (int r = 0; r < repeats; r++) {
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        run(v[14], v[15], n_out, v[17], sub, out);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        double s = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
        if (s < best) best = s;
    }
    printf("%.9e\n", best);
    for (int i = 0; i < n_out; i++) printf("%.17g\n", out[i]);
    free(out);
    return 0;
}
