/* Directional and time derivatives of a native FMU's equations (fmu_derivatives.h).
 *
 * The difference D(h) = (F(z + h) - F(z - h)) / 2h has the error c h^2 + O(h^4) on a smooth F, so
 * (4 D(h/2) - D(h)) / 3 has O(h^4): with h = 1e-5 of a variable's size that is far below rounding,
 * and rounding costs about 1e-16 / 1e-5 of the value.
 *
 * Along the trajectory: with zdot = (the states' rates, the inputs' rates) and zddot = (the
 * rates' own rate along zdot, 0: the inputs are lines), the path z(s) = z + s zdot + s^2/2 zddot
 * has the trajectory's first two derivatives at s = 0, so Y(s) = values(z(s)) has the outputs' first
 * and second time derivatives there: (Y(s) - Y(-s)) / 2s and (Y(s) - 2 Y(0) + Y(-s)) / s^2, each
 * with O(s^2) error (the odd terms cancel), extrapolated as above. s moves every variable by at
 * most 1e-3 of its size. */
#include "fmu_derivatives.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { FD_MAX_Z = 64 };

/* values and rates at z + s dz + s^2/2 ddz (ddz may be NULL) */
static int along(const FdModel* p, const double* dz, const double* ddz, double s, double* values, double* rates)
{
    double z[FD_MAX_Z];
    for (int j = 0; j < p->n_z; j++) z[j] = p->z[j] + s * dz[j] + (ddz ? 0.5 * s * s * ddz[j] : 0.0);
    return p->evaluate(p->model, z, values, rates);
}

/* the central difference of the values (or with rates_only, the states' rates) along dz by step h,
 * extrapolated: out[n] */
static int richardson(const FdModel* p, const double* dz, double h, int rates_only, double* out, double* work)
{
    size_t n = rates_only ? (size_t)p->n_states : p->n_values;
    double *plus = work, *minus = work + n, *coarse = work + 2 * n;
    for (int pass = 0; pass < 2; pass++) {
        double step = pass == 0 ? h : 0.5 * h;
        if (along(p, dz, NULL, step, rates_only ? NULL : plus, rates_only ? plus : NULL) != 0) return -1;
        if (along(p, dz, NULL, -step, rates_only ? NULL : minus, rates_only ? minus : NULL) != 0) return -1;
        double* d = pass == 0 ? coarse : out;
        for (size_t i = 0; i < n; i++) d[i] = (plus[i] - minus[i]) / (2.0 * step);
    }
    for (size_t i = 0; i < n; i++) out[i] = (4.0 * out[i] - coarse[i]) / 3.0;
    return 0;
}

static double* scratch(const FdModel* p, size_t extra)
{
    size_t n = p->n_values > (size_t)p->n_states ? p->n_values : (size_t)p->n_states;
    return (double*)malloc(sizeof(double) * (6 * n + extra + 1));
}

int fd_jacobian(const FdModel* p, const unsigned* knowns, size_t n_knowns, double* jacobian, size_t* refused)
{
    for (size_t k = 0; k < n_knowns; k++)
        if (p->known(p->model, knowns[k]) < 0) {
            *refused = k;
            return FD_NOT_A_KNOWN;
        }
    if (p->n_z > FD_MAX_Z) return FD_NOT_FINITE;
    double* work = scratch(p, p->n_values);
    if (!work) return FD_NOT_FINITE;
    double* column = work + 6 * (p->n_values > (size_t)p->n_states ? p->n_values : (size_t)p->n_states);
    double dz[FD_MAX_Z];
    int status = FD_OK;
    for (size_t k = 0; k < n_knowns && status == FD_OK; k++) {
        int j = p->known(p->model, knowns[k]);
        memset(dz, 0, sizeof dz);
        dz[j] = 1.0;
        status = richardson(p, dz, 1e-5 * p->scale[j], 0, column, work);
        for (size_t i = 0; i < p->n_values && status == FD_OK; i++) jacobian[i * n_knowns + k] = column[i];
    }
    free(work);
    return status;
}

int fd_time_derivatives(const FdModel* p, double* first, double* second)
{
    const double* input_rates = p->input_rates;
    if (p->n_z > FD_MAX_Z) return -1;
    size_t n = p->n_values > (size_t)p->n_states ? p->n_values : (size_t)p->n_states;
    double* work = scratch(p, 4 * n);
    if (!work) return -1;
    double *y0 = work + 6 * n, *plus = y0 + n, *minus = plus + n, *coarse = minus + n;
    double dz[FD_MAX_Z], ddz[FD_MAX_Z] = {0.0};
    int status = p->evaluate(p->model, p->z, y0, dz);
    double fastest = 0.0;                /* the largest rate relative to its variable's size */
    for (int j = p->n_states; j < p->n_z; j++) dz[j] = input_rates ? input_rates[j - p->n_states] : 0.0;
    for (int j = 0; j < p->n_z; j++) fastest = fmax(fastest, fabs(dz[j]) / p->scale[j]);
    if (status == 0 && !isfinite(fastest)) status = -1;
    if (status == 0 && fastest == 0.0) {         /* at rest, inputs held: the values stay */
        for (size_t i = 0; i < p->n_values; i++) {
            if (first) first[i] = 0.0;
            if (second) second[i] = 0.0;
        }
        free(work);
        return 0;
    }
    /* the states' second derivatives: their rates' change along the trajectory */
    if (status == 0 && p->n_states > 0) status = richardson(p, dz, 1e-5 / fastest, 1, ddz, work);
    double s = 1e-3 / fastest;
    double* coarse2 = work;              /* (richardson's work is done with) */
    for (int pass = 0; pass < 2 && status == 0; pass++) {
        double step = pass == 0 ? s : 0.5 * s;
        status = along(p, dz, ddz, step, plus, NULL);
        if (status == 0) status = along(p, dz, ddz, -step, minus, NULL);
        for (size_t i = 0; i < p->n_values && status == 0; i++) {
            double d1 = (plus[i] - minus[i]) / (2.0 * step), d2 = (plus[i] - 2.0 * y0[i] + minus[i]) / (step * step);
            if (pass == 0) {
                coarse[i] = d1;
                coarse2[i] = d2;
            } else {
                if (first) first[i] = (4.0 * d1 - coarse[i]) / 3.0;
                if (second) second[i] = (4.0 * d2 - coarse2[i]) / 3.0;
            }
        }
    }
    free(work);
    return status;
}
