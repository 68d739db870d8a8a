/* The transforms the mechanism model's tabulator (crank_tabulator.c) builds its tables with: a
 * radix-2 FFT with its twiddles, the real FFT of a row's samples, and the Fourier series of the
 * samples evaluated on a finer grid of angles (values or derivatives). Internal to the mechanism
 * model's files, as crank_mechanism_internal.h. */
#ifndef CRANK_FOURIER_H
#define CRANK_FOURIER_H

/* the twiddles of one transform size and its bit-reversal order; {0, NULL, NULL, NULL} is none yet */
typedef struct {
    int size;
    double *c, *s;
    int *reversed;
} mm_twiddles;

/* w made the twiddles of size (a power of two), computed where w holds another size; 0: no memory */
int mm_twiddles_for(mm_twiddles *w, int size);
void mm_twiddles_free(mm_twiddles *w);
/* in-place complex FFT of length n (a power of two, w its twiddles); inverse: the conjugate
 * direction, without the 1/n */
void mm_fft(double *re, double *im, int n, int inverse, const mm_twiddles *w);
/* the real-FFT coefficients (n/2 + 1 complex: sr, si) of n real samples x; wr, wi: n of work.
 * This and the series' evaluations return 0 where there is no memory for the twiddles, else 1 */
int mm_rfft(const double *x, int n, double *sr, double *si, double *wr, double *wi, mm_twiddles *tw);

/* the Fourier series of rows of n samples each: their coefficients, and what evaluating them on a
 * grid of m angles needs */
typedef struct {
    int rows, n;
    double *sr, *si;          /* rows x (n/2 + 1) */
    double *xr, *xi;          /* a padded spectrum, kept zero between uses */
    double *pc, *ps;          /* cos and sin of k shift, k <= n/2 */
    mm_twiddles *half, *full;
} mm_series;

/* cos and sin of k shift, k <= n/2: a grid's phases */
void mm_series_phases(int n, double shift, double *pc, double *ps);
/* one row of the series at m angles (+ the shift whose phases pc, ps are), value or derivative;
 * re, im: m/2 of work */
int mm_series_row(const mm_series *s, int r, int m, const double *pc, const double *ps, int derivative,
                  double *re, double *im, double *out);
/* the series of every row at m angles (+ shift), value or derivative: out rows x m */
int mm_series_values(mm_series *s, int m, double shift, int derivative, double *re, double *im, double *out);

#endif
