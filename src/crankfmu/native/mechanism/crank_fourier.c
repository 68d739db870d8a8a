/* The tabulator's transforms (crank_fourier.h): the radix-2 FFT and its twiddles, the real FFT,
 * and a Fourier series on a finer grid (dynamics/cubics.py and numerics.series_on_grid's
 * constructions, which crank_tabulator.c repeats in C). */
#include "crank_fourier.h"
#include "crank_mechanism_internal.h"

#include <math.h>
#include <stdlib.h>

void mm_twiddles_free(mm_twiddles *w)
{
    free(w->c);
    free(w->s);
    free(w->reversed);
    w->size = 0;
    w->c = w->s = NULL;
    w->reversed = NULL;
}

/* the twiddles of one transform size, computed once per size (a recurrence would drift by 1e-13
 * over a 4096-point transform), laid out stage by stage: entry half + k of stage len = 2 half is
 * e^{-2 pi i k / len}, so a stage reads its twiddles contiguously; and the bit-reversal order */
int mm_twiddles_for(mm_twiddles *w, int size)
{
    if (w->size == size) return 1;
    mm_twiddles_free(w);
    w->c = malloc(sizeof(double) * (size + 1));
    w->s = malloc(sizeof(double) * (size + 1));
    w->reversed = malloc(sizeof(int) * (size + 1));
    if (!w->c || !w->s || !w->reversed) return 0;
    /* the last stage's e^{-2 pi i k / size}, k < size/2, from cos and sin on the first eighth of
     * the turn and the symmetries of the others (exact: a swap and a sign). The second eighth's
     * cos and sin of (quarter - k) are the first eighth's entries quarter - k, read back: the same
     * calls on the same arguments, made once */
    int top = size / 2, eighth = size / 8, quarter = size / 4;
    double *c = w->c + top, *s = w->s + top;
    for (int k = 0; k < top; ++k) {
        double co, si;
        if (size < 8 || k <= eighth) {
            co = cos(TWO_PI * k / size);
            si = sin(TWO_PI * k / size);
        } else if (k <= quarter) {     /* (sin, cos) of quarter - k <= eighth; s holds -sin */
            co = -s[quarter - k];
            si = c[quarter - k];
        } else {                   /* angle pi/2 + x: (-sin x, cos x); s holds -sin */
            co = s[k - quarter];
            si = c[k - quarter];
        }
        c[k] = co;
        s[k] = -si;
    }
    /* the earlier stages: entry half + k is the last stage's entry k size / (2 half) */
    for (int half = 1; half < top; half <<= 1)
        for (int k = 0; k < half; ++k) {
            w->c[half + k] = c[k * (top / half)];
            w->s[half + k] = s[k * (top / half)];
        }
    for (int i = 0, j = 0; i < size; ++i) {
        w->reversed[i] = j;
        int bit = size >> 1;
        for (; bit && (j & bit); bit >>= 1) j ^= bit;
        j ^= bit;
    }
    w->size = size;
    return 1;
}

/* in-place radix-2 complex FFT of length n (a power of two, w its twiddles); inverse: the
 * conjugate direction, without the 1/n */
void mm_fft(double *re, double *im, int n, int inverse, const mm_twiddles *w)
{
    for (int i = 0; i < n; ++i) {
        int j = w->reversed[i];
        if (i < j) {
            double t = re[i]; re[i] = re[j]; re[j] = t;
            t = im[i]; im[i] = im[j]; im[j] = t;
        }
    }
    for (int i = 0; i + 1 < n; i += 2) {          /* the first stage: twiddle 1 */
        double tr = re[i + 1], ti = im[i + 1];
        re[i + 1] = re[i] - tr; im[i + 1] = im[i] - ti;
        re[i] += tr; im[i] += ti;
    }
    double sign = inverse ? -1.0 : 1.0;
    for (int half = 2; half < n; half <<= 1) {
        const double *wc = w->c + half, *ws = w->s + half;
        for (int i = 0; i < n; i += 2 * half) {
            double *ar = re + i, *ai = im + i, *br = ar + half, *bi = ai + half;
            for (int k = 0; k < half; ++k) {
                double cr = wc[k], ci = sign * ws[k];
                double tr = br[k] * cr - bi[k] * ci, ti = br[k] * ci + bi[k] * cr;
                br[k] = ar[k] - tr; bi[k] = ai[k] - ti;
                ar[k] += tr; ai[k] += ti;
            }
        }
    }
}

/* the real-FFT coefficients (n/2 + 1 complex) of n real samples */
int mm_rfft(const double *x, int n, double *sr, double *si, double *wr, double *wi, mm_twiddles *tw)
{
    if (!mm_twiddles_for(tw, n)) return 0;
    for (int i = 0; i < n; ++i) { wr[i] = x[i]; wi[i] = 0.0; }
    mm_fft(wr, wi, n, 0, tw);
    for (int k = 0; k <= n / 2; ++k) { sr[k] = wr[k]; si[k] = wi[k]; }
    return 1;
}

/* the interpolant of n samples (series ar, ai: n/2 + 1) or its derivative at k 2 pi / m + shift
 * (numerics.series_on_grid): the zero-padded Hermitian spectrum X (m/2 + 1 terms) inverted by one
 * complex transform of m/2 points, z_j = x_2j + i x_2j+1 = IDFT(E + i O) with
 * E_k = X_k + conj(X_{m/2-k}), O_k = (X_k - conj(X_{m/2-k})) e^{2 pi i k / m}.
 * pc, ps: cos and sin of k shift, k <= n/2 (mm_series' phases, one set for every row);
 * xr, xi: the padded spectrum, zero beyond n/2 on entry and on return. 0: no memory for the twiddles */
static int on_grid(const double *ar, const double *ai, int n, int m, const double *pc, const double *ps,
                    int derivative, double *xr, double *xi, double *re, double *im, mm_twiddles *half,
                    mm_twiddles *full, double *out)
{
    int h = m / 2, top = n / 2 < h ? n / 2 : h;
    if (!mm_twiddles_for(full, m) || !mm_twiddles_for(half, h)) return 0;
    for (int k = 0; k <= top; ++k) {
        double scale = (double)m / n * (k == n / 2 && m > n ? 0.5 : 1.0);
        double c = pc[k], s = ps[k];
        double vr = scale * (ar[k] * c - ai[k] * s), vi = scale * (ar[k] * s + ai[k] * c);
        if (derivative) { double t = -k * vi; vi = k * vr; vr = t; }
        xr[k] = vr;
        xi[k] = vi;
    }
    xi[0] = 0.0;
    xi[h] = 0.0;          /* irfft reads the real part of the Nyquist term */
    /* the full table's stage of length m holds e^{-2 pi i k / m}, k < m/2 */
    const double *fc = full->c + h, *fs = full->s + h;
    for (int k = 0; k < h; ++k) {
        double br = xr[h - k], bi = -xi[h - k];                 /* conj(X_{m/2-k}) */
        double er = xr[k] + br, ei = xi[k] + bi;
        double dr = xr[k] - br, di = xi[k] - bi;
        double wr = fc[k], wi = -fs[k];                         /* e^{+2 pi i k / m} */
        double orr = dr * wr - di * wi, oi = dr * wi + di * wr;
        re[k] = er - oi;                                        /* E + i O */
        im[k] = ei + orr;
    }
    for (int k = 0; k <= top; ++k) { xr[k] = 0.0; xi[k] = 0.0; }
    xr[h] = xi[h] = 0.0;
    mm_fft(re, im, h, 1, half);
    double inv = 1.0 / m;
    for (int j = 0; j < h; ++j) {
        out[2 * j] = re[j] * inv;
        out[2 * j + 1] = im[j] * inv;
    }
    return 1;
}

void mm_series_phases(int n, double shift, double *pc, double *ps)
{
    for (int k = 0; k <= n / 2; ++k) {
        pc[k] = cos(k * shift);
        ps[k] = sin(k * shift);
    }
}

/* one row of the series at m angles (+ the shift whose phases pc, ps are), value or derivative */
int mm_series_row(const mm_series *s, int r, int m, const double *pc, const double *ps, int derivative,
                  double *re, double *im, double *out)
{
    int w = s->n / 2 + 1;
    return on_grid(s->sr + r * w, s->si + r * w, s->n, m, pc, ps, derivative, s->xr, s->xi, re, im, s->half, s->full, out);
}

/* the series of every row at m angles (+ shift), value or derivative: out rows x m. Each row by
 * its own transform: two rows packed into one complex transform would leak each other's
 * rounding, and a row is checked relative to its own scale (an exact zero must stay zero) */
int mm_series_values(mm_series *s, int m, double shift, int derivative, double *re, double *im, double *out)
{
    mm_series_phases(s->n, shift, s->pc, s->ps);
    for (int r = 0; r < s->rows; ++r)
        if (!mm_series_row(s, r, m, s->pc, s->ps, derivative, re, im, out + (size_t)r * m)) return 0;
    return 1;
}
