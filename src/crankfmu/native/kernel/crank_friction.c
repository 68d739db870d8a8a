/* Joint friction in the kernel (crank_kernel.h, CkFriction): the frictions and the crank's
 * acceleration at one state, solved together from their tables. The rule is dynamics/friction.py's
 * (the reference engine solves it with Newton-Euler at each state; tests/test_friction_kernel.py
 * compares the two):
 *
 *   R_c = R0_c + sum_j H_cj f_j      each friction joint's reaction components, linear in the
 *                                    frictions once the acceleration is eliminated:
 *   R0_c = sum_t terms_ct w_t        the weights w at the frictionless acceleration eps0,
 *   H_cj = U_cj + R_eps_c k_j / J    U the unit frictions' terms, R_eps the acceleration's term
 *                                    (none where the motion is held: the motor sliding, or imposed)
 *   f_i = -c_i s_i |R_i|             Newton's method from f = 0 (the Jacobian I + c s d|R|/df)
 *   eps = eps0 + sum_i k_i f_i / J
 */
#include "crank_kernel_internal.h"

#include <math.h>

enum { MAX_ITERATIONS = 40 };

/* x <- the solution of A x = b (n <= CK_MAX_FRICTIONS, A row-major n x n, overwritten) by Gaussian
 * elimination with partial pivoting; 0, or -1 where A is singular */
static int solve_small(double* A, double* b, int n)
{
    for (int c = 0; c < n; c++) {
        int pivot = c;
        for (int r = c + 1; r < n; r++)
            if (fabs(A[r * n + c]) > fabs(A[pivot * n + c])) pivot = r;
        if (!(fabs(A[pivot * n + c]) > 0.0)) return -1;
        if (pivot != c) {
            for (int k = 0; k < n; k++) {
                double x = A[c * n + k];
                A[c * n + k] = A[pivot * n + k];
                A[pivot * n + k] = x;
            }
            double x = b[c];
            b[c] = b[pivot];
            b[pivot] = x;
        }
        for (int r = c + 1; r < n; r++) {
            double factor = A[r * n + c] / A[c * n + c];
            for (int k = c; k < n; k++) A[r * n + k] -= factor * A[c * n + k];
            b[r] -= factor * b[c];
        }
    }
    for (int c = n - 1; c >= 0; c--) {
        double x = b[c];
        for (int k = c + 1; k < n; k++) x -= A[c * n + k] * b[k];
        b[c] = x / A[c * n + c];
    }
    return 0;
}

/* every function of the friction table at phi into out: the table is interval-major (its functions
 * at one interval contiguous: a few cache lines per state, where the reduced table's function-major
 * layout would touch one line per function, each far from the last) */
static void interval_cubics(const double* coefficients, int n_functions, int n, double period, double phi,
                            double* out)
{
    double h = period / n;
    double wrapped = phi - period * floor(phi / period);
    if (!isfinite(wrapped)) {
        for (int f = 0; f < n_functions; f++) out[f] = NAN;
        return;
    }
    double x = wrapped / h;
    int i = x <= 0.0 ? 0 : (x >= n ? n - 1 : (int)x);
    double u = wrapped - i * h;
    const double* c = coefficients + (size_t)i * n_functions * 4;
    for (int f = 0; f < n_functions; f++, c += 4) out[f] = c[0] + u * (c[1] + u * (c[2] + u * c[3]));
}

double kernel_friction(double t, double phi, double omega, double direction, double interval, const CkTables* T,
                       const double* P, double J, double eps0, int held, double* f_out, double* normals)
{
    const CkFriction* F = T->friction;
    int nf = F->n_f, nt = F->n_terms, per = nt + nf;
    double values[CK_MAX_FRICTION_FUNCTIONS], w[4 + CK_MAX_FUNCTIONS + CK_MAX_PORTS];
    double R0[2 * CK_MAX_FRICTIONS], H[2 * CK_MAX_FRICTIONS][CK_MAX_FRICTIONS], f[CK_MAX_FRICTIONS];
    double cs[CK_MAX_FRICTIONS], A[CK_MAX_FRICTIONS * CK_MAX_FRICTIONS], step[CK_MAX_FRICTIONS];
    int n_components = 0;
    for (int i = 0; i < nf; i++) n_components += F->components[i];
    interval_cubics(F->coefficients, nf + n_components * per, F->n, T->period, phi, values);
    const double* k = values;
    kernel_reaction_weights(t, omega, eps0, direction, interval, T, P, w);
    const double* sign = F->signs + (size_t)interval * nf;
    for (int i = 0; i < nf; i++) {
        cs[i] = F->c[i] * sign[i] * direction;
        f[i] = 0.0;
    }
    for (int c = 0; c < n_components; c++) {
        const double* terms = values + nf + (size_t)c * per;
        double r = 0.0;
        for (int j = 0; j < nt; j++) r += terms[j] * w[j];
        R0[c] = r;
        for (int j = 0; j < nf; j++) H[c][j] = terms[nt + j] + (held ? 0.0 : terms[1] * k[j] / J);
    }
    /* Newton starts from the frictions of the frictionless reactions (-c s |R0|, one fixed-point
     * step from 0): the frictions are a small part of the reactions, so it starts an iteration
     * closer */
    for (int i = 0, c = 0; i < nf; c += F->components[i], i++)
        f[i] = -cs[i] * (F->components[i] == 2 ? sqrt(R0[c] * R0[c] + R0[c + 1] * R0[c + 1]) : fabs(R0[c]));
    for (int it = 0; it < MAX_ITERATIONS; it++) {
        double R[2 * CK_MAX_FRICTIONS], largest = 0.0;
        for (int c = 0; c < n_components; c++) {
            double r = R0[c];
            for (int j = 0; j < nf; j++) r += H[c][j] * f[j];
            R[c] = r;
            largest = fmax(largest, fabs(r));
        }
        int c = 0;
        for (int i = 0; i < nf; i++) {
            double magnitude, grad[CK_MAX_FRICTIONS];
            if (F->components[i] == 2) {
                double rx = R[c], ry = R[c + 1];
                magnitude = sqrt(rx * rx + ry * ry);      /* (reactions far from hypot's overflow) */
                for (int j = 0; j < nf; j++)
                    grad[j] = magnitude > 0.0 ? (rx * H[c][j] + ry * H[c + 1][j]) / magnitude : 0.0;
            } else {
                double n = R[c], s = n > 0.0 ? 1.0 : (n < 0.0 ? -1.0 : 0.0);
                magnitude = fabs(n);
                for (int j = 0; j < nf; j++) grad[j] = s * H[c][j];
            }
            c += F->components[i];
            step[i] = f[i] + cs[i] * magnitude;
            for (int j = 0; j < nf; j++) A[i * nf + j] = (i == j ? 1.0 : 0.0) + cs[i] * grad[j];
        }
        if (solve_small(A, step, nf) != 0) break;
        int settled = 1;
        for (int i = 0; i < nf; i++) {
            f[i] -= step[i];
            /* |R_i| is a difference of reactions as large as the largest: its round-off, weighted by
             * c_i, bounds how closely f_i can settle (the reference's criterion) */
            if (!(fabs(step[i]) <= 64.0 * 2.220446049250313e-16 * (fabs(f[i]) + F->c[i] * largest))) settled = 0;
        }
        if (settled) {
            double generalised = 0.0;
            for (int i = 0, c = 0; i < nf; c += F->components[i], i++) {
                generalised += k[i] * f[i];
                if (f_out) f_out[i] = f[i];
                /* (the normal force at the frictions before this last update: what |N| was taken of) */
                if (normals) normals[i] = F->components[i] == 1 ? R[c] : NAN;
            }
            return generalised;
        }
    }
    /* the frictions do not settle: friction large enough to lock the mechanism. NaN: the step is
     * refused as not finite */
    for (int i = 0; i < nf; i++) {
        if (f_out) f_out[i] = NAN;
        if (normals) normals[i] = NAN;
    }
    return NAN;
}

double kernel_friction_imposed(double t, double phi, double omega, double epsilon, double direction, double interval,
                               const CkTables* T, const double* P, double* f_out)
{
    if (T->friction == NULL) return 0.0;
    if (direction == 0.0) {          /* at rest, the crank held: no Coulomb force (ck_direction_imposed) */
        for (int i = 0; f_out && i < T->friction->n_f; i++) f_out[i] = 0.0;
        return 0.0;
    }
    /* held: the acceleration is given, so the frictions move the reactions alone (J is not read) */
    return kernel_friction(t, phi, omega, direction, interval, T, P, 1.0, epsilon, 1, f_out, NULL);
}
