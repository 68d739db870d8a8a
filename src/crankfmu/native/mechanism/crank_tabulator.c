/* The mechanism model's tabulator (crank_mechanism.h's mm_tabulate): a table's functions as periodic
 * Hermite cubics to a checked tolerance, from the Fourier series of the engine's samples, else from
 * the periodic cubic spline of up to 2^16 samples (dynamics/cubics.py's construction). */
#include "crank_fourier.h"
#include "crank_mechanism_internal.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int mm_table_turns(const mm_model *m, int table)
{
    int turns = m->program->cycle_turns;
    return table == MM_TABLE_QUANTITIES || turns < 1 ? 1 : turns;
}

/* The constructions below sample one period of 2 pi in theta = phi1 / turns (a table of a machine
 * cycle of several turns: its loads repeat over it); mm_tabulate rescales the cubics to phi1.
 * sample: the engine at angles theta (scaled to phi1 in place: every caller writes its angles
 * afresh before each call) */
static int sample(mm_model *m, int table, double *angles, int n, double *out)
{
    int turns = mm_table_turns(m, table);
    if (turns != 1)
        for (int i = 0; i < n; ++i) angles[i] *= turns;
    return mm_engine(m, table, angles, n, out);
}

/* the spline of samples (dynamics.cubics.from_samples), where the Fourier series does not
 * converge (a mechanism close to a dead point, a load with a kink in phi1): the C2 periodic cubic
 * spline of n samples (numerics.periodic_cubic_spline: its second derivatives M from the circulant
 * [1 4 1] system, solved by one transform each way), n doubling from 256 until the spline agrees
 * with the engine to tolerance at every interval's midpoint and 0.3 in; with 2^16 intervals, kept
 * where it is within loosest */

static int from_samples(mm_model *m, int table, double tolerance, double **cubics_out, int *m_out, double *error_out)
{
    const int rows = mm_rows(m, table), n_start = 256, n_max = 1 << 16;
    const double loosest = 1e-8;
    int status = MM_OK;
    double *values = NULL, *exact = NULL, *angles = NULL, *cubics = NULL, *re = NULL, *im = NULL, *eigen = NULL;
    double *errors = NULL;
    mm_twiddles tw = {0, NULL, NULL, NULL};
    for (int n = n_start;; n *= 2) {
        double h = TWO_PI / n;
        free(values); free(exact); free(angles); free(cubics); free(re); free(im); free(eigen); free(errors);
        values = malloc(sizeof(double) * rows * n);
        exact = malloc(sizeof(double) * rows * 2 * n);
        angles = malloc(sizeof(double) * 2 * n);
        cubics = malloc(sizeof(double) * rows * n * 4);
        re = malloc(sizeof(double) * n);
        im = malloc(sizeof(double) * n);
        eigen = malloc(sizeof(double) * n);
        errors = malloc(sizeof(double) * (rows > 0 ? rows : 1));
        if (!values || !exact || !angles || !cubics || !re || !im || !eigen || !errors || !mm_twiddles_for(&tw, n)) {
            status = MM_NO_MEMORY;
            break;
        }
        for (int i = 0; i < n; ++i) angles[i] = i * h;
        if ((status = sample(m, table, angles, n, values))) break;
        for (int i = 0; i < n; ++i) { angles[i] = (i + 0.5) * h; angles[n + i] = (i + 0.3) * h; }
        if ((status = sample(m, table, angles, 2 * n, exact))) break;
        for (int k = 0; k < n; ++k) eigen[k] = 4.0 + 2.0 * cos(TWO_PI * k / n);
        double error = 0.0;
        int worst = 0;
        for (int r = 0; r < rows; ++r) {
            const double *y = values + (size_t)r * n;
            double *c = cubics + (size_t)r * n * 4;
            for (int i = 0; i < n; ++i) {
                re[i] = 6.0 * (y[(i + 1) % n] - 2.0 * y[i] + y[(i + n - 1) % n]) / (h * h);
                im[i] = 0.0;
            }
            mm_fft(re, im, n, 0, &tw);
            for (int k = 0; k < n; ++k) { re[k] /= eigen[k]; im[k] /= eigen[k]; }
            mm_fft(re, im, n, 1, &tw);                     /* M = re / n */
            double scale = 1e-300;
            for (int i = 0; i < n; ++i) scale = fmax(scale, fabs(y[i]));
            for (int i = 0; i < n; ++i) {
                double M = re[i] / n, M1 = re[(i + 1) % n] / n, y1 = y[(i + 1) % n];
                c[4 * i] = y[i];
                c[4 * i + 1] = (y1 - y[i]) / h - h * (2.0 * M + M1) / 6.0;
                c[4 * i + 2] = 0.5 * M;
                c[4 * i + 3] = (M1 - M) / (6.0 * h);
            }
            double e = 0.0;
            for (int j = 0; j < 2 * n; ++j) {
                const double *ci = c + 4 * (j % n);
                double u = (j < n ? 0.5 : 0.3) * h;
                double d = fabs(ci[0] + u * (ci[1] + u * (ci[2] + u * ci[3])) - exact[(size_t)r * 2 * n + j]) / scale;
                if (!(d <= e)) e = d;
            }
            errors[r] = e;
            if (!(e <= error)) { error = e; worst = r; }
        }
        if (error <= tolerance || (2 * n > n_max && error <= loosest)) {
            *cubics_out = cubics;
            cubics = NULL;
            *m_out = n;
            *error_out = error;
            break;
        }
        if (2 * n > n_max) {
            /* where the worst function changes fastest, and whether that is a jump */
            const double *y = values + (size_t)worst * n;
            int k = 0;
            for (int i = 0; i < n; ++i) {
                exact[i] = fabs(y[(i + 1) % n] - y[i]);
                if (exact[i] > exact[k]) k = i;
            }
            double step = y[(k + 1) % n] - y[k];
            /* look inside the interval (dynamics/cubics.py's rule): a jump stays in one of 1024
             * sub-intervals however fine; a steep function (the kinematics near a dead point, a
             * peaky load) spreads its change over many */
            enum { FINE = 1024 };
            double *fine = malloc(sizeof(double) * (size_t)rows * (FINE + 1)), *at = malloc(sizeof(double) * (FINE + 1));
            if (!fine || !at) {
                free(fine); free(at);
                status = MM_NO_MEMORY;
                break;
            }
            for (int j = 0; j <= FINE; ++j) at[j] = (k + (double)j / FINE) * h;
            status = sample(m, table, at, FINE + 1, fine);
            int jumps = 0;
            if (status == MM_OK) {
                const double *inside = fine + (size_t)worst * (FINE + 1);
                double largest = 0.0;
                for (int j = 0; j < FINE; ++j) {
                    at[j] = fabs(inside[j + 1] - inside[j]);
                    if (at[j] > largest) largest = at[j];
                }
                qsort(at, FINE, sizeof(double), mm_ascending);
                double median = 0.5 * (at[FINE / 2 - 1] + at[FINE / 2]);
                jumps = fabs(step) > 0.0 && largest > 0.5 * fabs(step) && largest > 1e3 * median + 1e-300;
            }
            free(fine); free(at);
            if (status != MM_OK) break;                  /* not finite inside: mm_engine said where */
            m->error_index = worst;
            m->error_value = error;
            m->error_angle = k * h * mm_table_turns(m, table);          /* phi1, not theta */
            m->error_step = step;
            m->error_jumps = jumps;
            status = MM_NOT_TABULATED;
            break;
        }
    }
    free(values); free(exact); free(angles); free(cubics); free(re); free(im); free(eigen); free(errors);
    mm_twiddles_free(&tw);
    return status;
}

/* *p grown to hold count doubles (its contents kept); zero: the new part zeroed */
static int grow(double **p, size_t count, size_t *capacity, int zero)
{
    if (count <= *capacity) return 1;
    double *q = realloc(*p, sizeof(double) * count);
    if (!q) return 0;
    if (zero) memset(q + *capacity, 0, sizeof(double) * (count - *capacity));
    *p = q;
    *capacity = count;
    return 1;
}

/* the series stage's working memory for n samples (and a check set of n + n/4 angles), grown to
 * 2n before n doubles (the midpoints interleaved into work, then copied to samples): sized to the
 * n reached, not to the largest n allowed, so that a table's peak memory is its own cubics and a
 * few rows (a process that tabulates design after design then reuses the same heap instead of
 * growing it and handing it back to the system every time) */
typedef struct {
    uint64_t *hash;
    int *same;
    double *samples, *exact, *angles, *work, *scale, *re, *im, *phases;
    size_t samples_n, exact_n, angles_n, work_n, scale_n, re_n, im_n, phases_n, sr_n, si_n, xr_n, xi_n, pc_n, ps_n;
} tabulator_memory;

static int series_memory(tabulator_memory *t, mm_series *s, int rows, int n)
{
    size_t r = (size_t)(rows > 0 ? rows : 1), checks = (size_t)n + n / 4, w = (size_t)n / 2 + 1;
    return grow(&t->samples, r * n, &t->samples_n, 0) && grow(&t->exact, r * checks, &t->exact_n, 0) &&
           grow(&t->angles, 2 * checks, &t->angles_n, 0) && grow(&t->work, r * n, &t->work_n, 0) &&
           grow(&t->scale, r, &t->scale_n, 0) && grow(&t->re, (size_t)n, &t->re_n, 0) &&
           grow(&t->im, (size_t)n, &t->im_n, 0) && grow(&t->phases, 4 * w, &t->phases_n, 0) &&
           grow(&s->sr, r * w, &t->sr_n, 0) && grow(&s->si, r * w, &t->si_n, 0) &&
           grow(&s->xr, w, &t->xr_n, 1) && grow(&s->xi, w, &t->xi_n, 1) && grow(&s->pc, w, &t->pc_n, 0) &&
           grow(&s->ps, w, &t->ps_n, 0);
}

/* the bits of a row's samples and checks, mixed into 64 (FNV-1a over 64-bit words): rows with
 * other values almost never share it, and rows that share it are compared in full */
static uint64_t row_hash(const double *samples, int n, const double *checks, int n_checks)
{
    uint64_t h = 1469598103934665603u, word;
    for (int i = 0; i < n + n_checks; ++i) {
        memcpy(&word, i < n ? samples + i : checks + (i - n), sizeof word);
        h = (h ^ word) * 1099511628211u;
    }
    return h;
}

/* for each row, an earlier row with the same samples and checks bit for bit, else -1: its series,
 * scale, cubics and measured error are that row's (the same operations on the same numbers), so
 * they are copied, not computed again. A joint reaction table has many such rows: a term that
 * does not reach a joint is zero there (seed 001: 120 rows, 61 distinct) */
static void same_rows(int rows, int n, const double *samples, int n_checks, const double *checks, uint64_t *hash,
                      int *same)
{
    for (int r = 0; r < rows; ++r) {
        const double *y = samples + (size_t)r * n, *c = checks + (size_t)r * n_checks;
        hash[r] = row_hash(y, n, c, n_checks);
        same[r] = -1;
        for (int q = 0; q < r && same[r] < 0; ++q)
            if (same[q] < 0 && hash[q] == hash[r] && !memcmp(samples + (size_t)q * n, y, sizeof(double) * n) &&
                !memcmp(checks + (size_t)q * n_checks, c, sizeof(double) * n_checks))
                same[r] = q;
    }
}

static int tabulate_period(mm_model *m, int table, double tolerance, double **cubics_out, int *m_out,
                           double *error_out, int *n_series);

int mm_tabulate(mm_model *m, int table, double tolerance, double **cubics_out, int *m_out, double *error_out,
                int *n_series)
{
    int status = tabulate_period(m, table, tolerance, cubics_out, m_out, error_out, n_series);
    int turns = mm_table_turns(m, table);
    if (status == MM_OK && turns != 1) {
        /* the cubics in theta to phi1 = turns theta: u_phi = turns u_theta, c_k / turns^k */
        const double t1 = turns, t2 = t1 * t1, t3 = t2 * t1;     /* (as dynamics/cubics.py divides) */
        size_t count = (size_t)mm_rows(m, table) * (size_t)*m_out;
        for (size_t i = 0; i < count; ++i) {
            double *c = *cubics_out + 4 * i;
            c[1] /= t1;
            c[2] /= t2;
            c[3] /= t3;
        }
    }
    return status;
}

/* mm_tabulate over one period of 2 pi in theta */
static int tabulate_period(mm_model *m, int table, double tolerance, double **cubics_out, int *m_out,
                           double *error_out, int *n_series)
{
    const int rows = mm_rows(m, table), n_first = 64, n_last = 4096, m_last = 1 << 16;
    const double budget = 0.5 * tolerance;
    int n = n_first, status = MM_OK;
    double last = INFINITY, error = 0.0;
    tabulator_memory t;
    memset(&t, 0, sizeof t);
    mm_twiddles half = {0, NULL, NULL, NULL}, full = {0, NULL, NULL, NULL}, forward = {0, NULL, NULL, NULL};
    mm_series s = {rows, 0, NULL, NULL, NULL, NULL, NULL, NULL, &half, &full};
    double *values = NULL, *slopes = NULL, *cubics = NULL;
    if (!series_memory(&t, &s, rows, n)) { status = MM_NO_MEMORY; goto done; }
    double *samples = t.samples, *exact = t.exact, *angles = t.angles, *work = t.work, *scale = t.scale;
    double *re = t.re, *im = t.im, *phases = t.phases;

    /* the first samples and their checks in one engine call */
    {
        double h = TWO_PI / n;
        int c = 0;
        for (int i = 0; i < n; ++i) angles[c++] = i * h;
        for (int i = 0; i < n; ++i) angles[c++] = (i + 0.5) * h;
        for (int i = 0; i < n; i += 4) angles[c++] = (i + 0.3) * h;
        double *first = malloc(sizeof(double) * rows * c);
        if (!first) { status = MM_NO_MEMORY; goto done; }
        status = sample(m, table, angles, c, first);
        for (int r = 0; r < rows && status == MM_OK; ++r) {
            memcpy(samples + r * n, first + r * c, sizeof(double) * n);
            memcpy(exact + r * (c - n), first + r * c + n, sizeof(double) * (c - n));
        }
        free(first);
        if (status) goto done;
    }
    for (;;) {
        double h = TWO_PI / n;
        int checks = n + n / 4;
        for (int r = 0; r < rows; ++r) {
            double big_value = 1e-300;
            for (int i = 0; i < n; ++i) big_value = fmax(big_value, fabs(samples[r * n + i]));
            for (int i = 0; i < checks; ++i) big_value = fmax(big_value, fabs(exact[r * checks + i]));
            scale[r] = big_value;
        }
        s.n = n;
        for (int r = 0; r < rows; ++r)
            if (!mm_rfft(samples + r * n, n, s.sr + r * (n / 2 + 1), s.si + r * (n / 2 + 1), re, im, &forward)) {
                status = MM_NO_MEMORY;
                goto done;
            }
        /* the interpolant at the midpoints, and at 0.3 of every fourth interval */
        if (!mm_series_values(&s, n, 0.5 * h, 0, re, im, work)) { status = MM_NO_MEMORY; goto done; }
        error = 0.0;
        for (int r = 0; r < rows; ++r)
            for (int i = 0; i < n; ++i) {
                double e = fabs(work[r * n + i] - exact[r * checks + i]) / scale[r];
                if (!(e <= error)) error = e;
            }
        if (!mm_series_values(&s, n, 0.3 * h, 0, re, im, work)) { status = MM_NO_MEMORY; goto done; }
        for (int r = 0; r < rows; ++r)
            for (int i = 0; i < n; i += 4) {
                double e = fabs(work[r * n + i] - exact[r * checks + n + i / 4]) / scale[r];
                if (!(e <= error)) error = e;
            }
        if (error <= budget) break;
        if (2 * n > n_last || (n >= 4 * n_first && error > 0.25 * last)) { status = MM_NOT_TABULATED; goto spline; }
        last = error;
        if (!series_memory(&t, &s, rows, 2 * n)) { status = MM_NO_MEMORY; goto done; }
        samples = t.samples; exact = t.exact; angles = t.angles; work = t.work; re = t.re; im = t.im;
        phases = t.phases;
        /* the midpoints become samples */
        for (int r = 0; r < rows; ++r)
            for (int i = n - 1; i >= 0; --i) {
                work[r * 2 * n + 2 * i] = samples[r * n + i];
                work[r * 2 * n + 2 * i + 1] = exact[r * checks + i];
            }
        n *= 2;
        memcpy(samples, work, sizeof(double) * rows * n);
        h = TWO_PI / n;
        int c = 0;
        for (int i = 0; i < n; ++i) angles[c++] = (i + 0.5) * h;
        for (int i = 0; i < n; i += 4) angles[c++] = (i + 0.3) * h;
        if ((status = sample(m, table, angles, c, exact))) goto done;
    }
    /* the Hermite cubics of the series on mm intervals, by its bound on the fourth derivative */
    {
        double fourth = 0.0;
        int w = n / 2 + 1;
        for (int r = 0; r < rows; ++r) {
            double sum = 0.0;
            for (int k = 0; k < w; ++k) {
                double a = hypot(s.sr[r * w + k], s.si[r * w + k]) * (2.0 / n) * (k == 0 ? 0.5 : 1.0);
                double k2 = (double)k * k;
                sum += k2 * k2 * a;
            }
            fourth = fmax(fourth, sum / scale[r]);
        }
        t.hash = malloc(sizeof(uint64_t) * (rows > 0 ? rows : 1));
        t.same = malloc(sizeof(int) * (rows > 0 ? rows : 1));
        if (!t.hash || !t.same) { status = MM_NO_MEMORY; goto done; }
        same_rows(rows, n, samples, n + n / 4, exact, t.hash, t.same);
        double predicted = TWO_PI * pow(fourth / (384.0 * budget), 0.25);
        int mm = 1 << (int)nearbyint(log2(fmax(predicted, 1.0)));
        if (mm < n) mm = n;
        if (mm > m_last) mm = m_last;
        for (;;) {
            double hm = TWO_PI / mm;
            free(values); free(slopes); free(cubics);
            values = slopes = cubics = NULL;
            if (!grow(&t.re, (size_t)mm, &t.re_n, 0) || !grow(&t.im, (size_t)mm, &t.im_n, 0) ||
                !grow(&s.xr, (size_t)mm / 2 + 1, &t.xr_n, 1) || !grow(&s.xi, (size_t)mm / 2 + 1, &t.xi_n, 1)) {
                status = MM_NO_MEMORY;
                goto done;
            }
            re = t.re; im = t.im;
            /* one row at a time: its values and slopes stay in cache, only the cubics are kept */
            values = malloc(sizeof(double) * mm);
            slopes = malloc(sizeof(double) * mm);
            cubics = malloc(sizeof(double) * rows * mm * 4);
            if (!values || !slopes || !cubics) { status = MM_NO_MEMORY; goto done; }
            double cubic_error = pow(hm, 4) / 384.0 * fourth;
            /* the bound is pessimistic: where it exceeds the budget, measure at the midpoints */
            int measure = cubic_error > budget;
            if (measure) cubic_error = 0.0;
            double *pc = phases, *ps = phases + w, *mid_c = phases + 2 * w, *mid_s = phases + 3 * w;
            mm_series_phases(n, 0.0, pc, ps);
            mm_series_phases(n, 0.5 * hm, mid_c, mid_s);
            for (int r = 0; r < rows; ++r) {
                if (t.same[r] >= 0) {
                    memcpy(cubics + (size_t)r * mm * 4, cubics + (size_t)t.same[r] * mm * 4, sizeof(double) * mm * 4);
                    continue;
                }
                if (!mm_series_row(&s, r, mm, pc, ps, 0, re, im, values) ||
                    !mm_series_row(&s, r, mm, pc, ps, 1, re, im, slopes)) {
                    status = MM_NO_MEMORY;
                    goto done;
                }
                const double inv_h = 1.0 / hm, inv_h2 = inv_h * inv_h;
                for (int i = 0; i < mm; ++i) {
                    int next = i + 1 < mm ? i + 1 : 0;
                    double y = values[i], y1 = values[next];
                    double d = slopes[i], d1 = slopes[next];
                    double secant = (y1 - y) * inv_h;
                    double cubic = d + d1 - 2.0 * secant;
                    double *c = cubics + ((size_t)r * mm + i) * 4;
                    c[0] = y;
                    c[1] = d;
                    c[2] = (secant - d - cubic) * inv_h;
                    c[3] = cubic * inv_h2;
                }
                if (measure) {
                    if (!mm_series_row(&s, r, mm, mid_c, mid_s, 0, re, im, values)) { status = MM_NO_MEMORY; goto done; }
                    double u = 0.5 * hm;
                    for (int i = 0; i < mm; ++i) {
                        const double *c = cubics + ((size_t)r * mm + i) * 4;
                        double e = fabs(c[0] + u * (c[1] + u * (c[2] + u * c[3])) - values[i]) / scale[r];
                        if (!(e <= cubic_error)) cubic_error = e;
                    }
                }
            }
            if (cubic_error <= budget) {
                *cubics_out = cubics;
                cubics = NULL;
                *m_out = mm;
                *error_out = error + cubic_error;
                *n_series = n;
                break;
            }
            int doubling = (int)ceil(0.25 * log2(cubic_error / budget));
            mm <<= doubling > 1 ? doubling : 1;
            if (mm > m_last) { status = MM_NOT_TABULATED; goto spline; }
        }
    }
spline:
    if (status == MM_NOT_TABULATED) {
        /* the series does not converge: the spline of samples, its memory of its own */
        free(values); free(slopes); free(cubics);
        values = slopes = cubics = NULL;
        status = from_samples(m, table, tolerance, cubics_out, m_out, error_out);
        *n_series = 0;
    }
done:
    free(t.hash); free(t.same); free(t.samples); free(t.exact); free(t.angles); free(t.scale);
    free(t.re); free(t.im); free(t.work); free(t.phases);
    free(s.sr); free(s.si); free(s.xr); free(s.xi); free(s.pc); free(s.ps); free(values); free(slopes); free(cubics);
    mm_twiddles_free(&half);
    mm_twiddles_free(&full);
    mm_twiddles_free(&forward);
    return status;
}

void mm_release(double *cubics)
{
    free(cubics);
}
