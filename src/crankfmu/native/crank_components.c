/* The components' physics (crank_components.h). */
#include <math.h>
#include <string.h>

#include "crank_components.h"

double cc_drive_voltage(const double* d, double x, double omega, double omega_set)
{
    return d[CC_KP] * (omega_set - omega) + d[CC_KI] * x;
}

double cc_drive_torque(const double* d, double i) { return d[CC_N_GEAR] * d[CC_K_T] * i; }

/* With the inputs held, x grows linearly (dx/dt = e) and L di/dt = p L + q L t - R i: the current
 * relaxes with the time constant L/R towards an affine function of time, solved in closed form
 * (expm1 keeps 1 - exp(-a h) exact for small steps). */
void cc_drive_step(const double* d, double i, double x, double omega, double omega_set, double h, double* out)
{
    double e = omega_set - omega;
    double a = d[CC_R] / d[CC_L];
    double p = (d[CC_KP] * e + d[CC_KI] * x - d[CC_K_T] * d[CC_N_GEAR] * omega) / d[CC_L];   /* A/s */
    double q = d[CC_KI] * e / d[CC_L];                                                       /* A/s2 */
    double one_minus = -expm1(-a * h);
    out[0] = i * (1.0 - one_minus) + p * one_minus / a + q * (h / a - one_minus / (a * a));
    out[1] = x + e * h;
}

static void matmul4(const double* A, const double* B, double* C)
{
    double t[16];
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++) s += A[r * 4 + k] * B[k * 4 + c];
            t[r * 4 + c] = s;
        }
    memcpy(C, t, sizeof t);
}

/* M / 2^s has a norm of at most 1/2, where 20 terms of the series reach rounding; then s squarings
 * (numerics.expm states the same method, its reference) */
void cc_expm4(const double* M, double* out)
{
    double norm = 0.0;
    for (int r = 0; r < 4; r++) {
        double row = 0.0;
        for (int c = 0; c < 4; c++) row += fabs(M[r * 4 + c]);
        if (row > norm) norm = row;
    }
    int s = 0;
    if (norm > 0.0 && isfinite(norm)) {
        s = (int)ceil(log2(norm)) + 1;
        if (s < 0) s = 0;
        if (s > 1000) s = 1000;
    }
    double X[16], term[16], sum[16];
    double scale = ldexp(1.0, -s);
    for (int k = 0; k < 16; k++) {
        X[k] = M[k] * scale;
        term[k] = (k % 5 == 0) ? 1.0 : 0.0;
        sum[k] = term[k];
    }
    for (int n = 1; n <= 20; n++) {
        matmul4(term, X, term);
        for (int k = 0; k < 16; k++) {
            term[k] /= n;
            sum[k] += term[k];
        }
    }
    for (int n = 0; n < s; n++) matmul4(sum, sum, sum);
    memcpy(out, sum, sizeof sum);
}

void cc_drive_step_with_rotor(const double* d, double i, double x, double omega, double omega_set, double tau_load,
                              double J_drive, double h, double* out)
{
    double nk = d[CC_N_GEAR] * d[CC_K_T], L = d[CC_L];
    double A[16] = {-d[CC_R] / L * h, d[CC_KI] / L * h, -(d[CC_KP] + nk) / L * h, d[CC_KP] * omega_set / L * h,
                    0.0, 0.0, -h, omega_set * h,
                    nk / J_drive * h, 0.0, 0.0, -tau_load / J_drive * h,
                    0.0, 0.0, 0.0, 0.0};
    double E[16];
    cc_expm4(A, E);
    double z[4] = {i, x, omega, 1.0};
    for (int r = 0; r < 3; r++) out[r] = E[r * 4] * z[0] + E[r * 4 + 1] * z[1] + E[r * 4 + 2] * z[2] + E[r * 4 + 3];
}

double cc_cushion_force(double k, double c, double L_free, double s_seat, double s, double v)
{
    return -(k * ((s - s_seat) - L_free) + c * v);
}
