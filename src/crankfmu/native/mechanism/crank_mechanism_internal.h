/* What the mechanism model's files share, and nothing outside them includes: the evaluator, the
 * linear algebra and the contour kinematics (crank_mechanism.c) that the assembly check and
 * searches (crank_assembly.c), the tables' functions (crank_engine.c) and the tabulator
 * (crank_tabulator.c) build on. The public interface is crank_mechanism.h. */
#ifndef CRANK_MECHANISM_INTERNAL_H
#define CRANK_MECHANISM_INTERNAL_H

#include "crank_mechanism.h"

#include <math.h>

#define TWO_PI 6.283185307179586
#define MAX_Q 24
#define MAX_LINKS 21

/* a contour term at positions q: its length, and the cosine and sine of its angle */
typedef struct { double L, c, s; } term_value;

/* run one section of the program on the registers r */
void mm_run(const mm_program *p, double *r, int section);
/* LU factors of A (n x n row-major, partial pivoting) in place, its signed determinant into *det;
 * 0 where A is singular */
int mm_lu_factor(int n, double *A, int *piv, double *det);
void mm_lu_solve(int n, const double *LU, const int *piv, double *b);
/* the contours' terms at positions q */
void mm_terms_at(const mm_model *m, const double *q, term_value *t);
/* the contour equations' largest residual at the terms t, m */
double mm_residual_max(const mm_model *m, const term_value *t);
/* the contours' Jacobian J at the terms t, the LU factors of its unknowns' block Ju and the signed
 * conditioning (*cond, may be NULL); MM_SINGULAR where Ju is singular */
int mm_factor_unknowns(const mm_model *m, const term_value *t, double *J, double *Ju, int *piv, double *cond);
/* q', q'' at solved positions (their terms t); the signed conditioning into *cond (may be NULL) */
int mm_transfer(const mm_model *m, const term_value *t, double *dq, double *ddq, double *cond);
/* the closed form's positions at phi1, its angles as the expressions give them */
int mm_closed_positions(mm_model *m, double phi1, double *q);
/* the positions at phi1 on the continuous branch (closed form or Newton from the turn table) */
int mm_positions(mm_model *m, double phi1, double *q);
/* the kinematics at phi1 from the positions q into the registers; the signed conditioning into
 * *cond and the contours' largest residual at q into *residual_out (each may be NULL) */
int mm_kinematics_of(mm_model *m, double phi1, const double *q, double *cond, double *residual_out);
int mm_kinematics(mm_model *m, double phi1, double *cond);
/* the per-angle registers phi1 .. the last point's: what a scan angle's kinematics leave */
int mm_kinematics_width(const mm_program *p);

/* value moved by whole turns to the one nearest reference: how an angle is made continuous along
 * the turn (numpy.unwrap's rule) and put on the turn table's branch */
static inline double mm_nearest_turn(double reference, double value)
{
    return value + TWO_PI * nearbyint((reference - value) / TWO_PI);
}

/* qsort's order of doubles */
static inline int mm_ascending(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

#endif
