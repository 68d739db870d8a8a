/* The mechanism model in C (crank_mechanism.h): the program's evaluator, the contour kinematics,
 * the assembly check and searches, and the tabulator. Re-entrant: everything lives in mm_model. */
#include "crank_mechanism.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TWO_PI 6.283185307179586
#define MAX_Q 24
#define MAX_LINKS 21

/* ------------------------------------------------------------------------------ the evaluator */
static void run(const mm_program *p, double *r, int section)
{
    const int *code = p->code + 5 * p->sections[2 * section];
    const int *end = p->code + 5 * p->sections[2 * section + 1];
    for (; code < end; code += 5) {
        double a = r[code[2]], b = r[code[3]];
        double v;
        switch (code[0]) {
        case MM_LITERAL: v = p->literals[code[2]]; break;
        case MM_COPY: v = a; break;
        case MM_ADD: v = a + b; break;
        case MM_SUB: v = a - b; break;
        case MM_MUL: v = a * b; break;
        case MM_DIV: v = a / b; break;
        case MM_POW: v = (b == 2.0) ? a * a : pow(a, b); break;
        case MM_NEG: v = -a; break;
        case MM_SIN: v = sin(a); break;
        case MM_COS: v = cos(a); break;
        case MM_TAN: v = tan(a); break;
        case MM_ASIN: v = asin(a); break;
        case MM_ACOS: v = acos(a); break;
        case MM_ATAN: v = atan(a); break;
        case MM_ATAN2: v = atan2(a, b); break;
        case MM_SQRT: v = sqrt(a); break;
        case MM_HYPOT: v = hypot(a, b); break;
        case MM_EXP: v = exp(a); break;
        case MM_LOG: v = log(a); break;
        case MM_ABS: v = fabs(a); break;
        case MM_SIGN: v = (a > 0) ? 1.0 : (a < 0) ? -1.0 : (a == 0 ? 0.0 : a); break;
        case MM_MIN: v = (a != a || b != b) ? NAN : (a < b ? a : b); break;
        case MM_MAX: v = (a != a || b != b) ? NAN : (a > b ? a : b); break;
        case MM_RADIANS: v = a * (3.141592653589793 / 180.0); break;
        case MM_DEGREES: v = a * (180.0 / 3.141592653589793); break;
        case MM_IF_POSITIVE: v = (a > 0.0) ? b : r[code[4]]; break;
        case MM_IF_NEGATIVE: v = (a < 0.0) ? b : r[code[4]]; break;
        case MM_NOT_ABOVE: v = (a <= b) ? 1.0 : 0.0; break;
        default: v = NAN;
        }
        r[code[1]] = v;
    }
}

/* --------------------------------------------------------------------------- linear algebra */
/* LU factors of A (n x n row-major, partial pivoting) in place, its signed determinant into *det;
 * 0 when A is singular */
static int lu_factor(int n, double *A, int *piv, double *det)
{
    double d = 1.0;
    for (int k = 0; k < n; ++k) {
        int p = k;
        for (int i = k + 1; i < n; ++i)
            if (fabs(A[i * n + k]) > fabs(A[p * n + k])) p = i;
        piv[k] = p;
        if (A[p * n + k] == 0.0 || !isfinite(A[p * n + k])) { *det = 0.0; return 0; }
        if (p != k) {
            d = -d;
            for (int j = 0; j < n; ++j) { double t = A[k * n + j]; A[k * n + j] = A[p * n + j]; A[p * n + j] = t; }
        }
        double pivot = A[k * n + k];
        d *= pivot;
        for (int i = k + 1; i < n; ++i) {
            double f = A[i * n + k] / pivot;
            A[i * n + k] = f;
            if (f == 0.0) continue;
            for (int j = k + 1; j < n; ++j) A[i * n + j] -= f * A[k * n + j];
        }
    }
    *det = d;
    return 1;
}

static void lu_solve(int n, const double *LU, const int *piv, double *b)
{
    /* the rows were swapped whole (the multipliers with them): every swap first, then L */
    for (int k = 0; k < n; ++k)
        if (piv[k] != k) { double t = b[k]; b[k] = b[piv[k]]; b[piv[k]] = t; }
    for (int k = 0; k < n; ++k)
        for (int i = k + 1; i < n; ++i) b[i] -= LU[i * n + k] * b[k];
    for (int i = n - 1; i >= 0; --i) {
        double s = b[i];
        for (int m = i + 1; m < n; ++m) s -= LU[i * n + m] * b[m];
        b[i] = s / LU[i * n + i];
    }
}

static int solve(int n, double *A, double *b)
{
    int piv[64];
    double det;
    if (!lu_factor(n, A, piv, &det)) return 0;
    lu_solve(n, A, piv, b);
    return 1;
}

/* ------------------------------------------------------------------------------ the contours */
typedef struct { double L, c, s; } term_value;

static void terms_at(const mm_model *m, const double *q, term_value *t)
{
    const mm_program *p = m->program;
    const double *r = m->registers;
    /* terms share few distinct angles (a link's angle plus a constant offset): cos and sin once each */
    double c[256], s[256];
    for (int k = 0; k < p->n_angles; ++k) {
        const int *a = p->angles + 2 * k;
        double th = (a[0] >= 0 ? q[a[0]] : 0.0) + r[a[1]];
        c[k] = cos(th);
        s[k] = sin(th);
    }
    for (int i = 0; i < p->n_terms; ++i) {
        const int *f = p->terms + MM_TERM_FIELDS * i;
        t[i].L = r[f[1]] * (f[2] >= 0 ? q[f[2]] : 1.0);
        t[i].c = c[f[5]];
        t[i].s = s[f[5]];
    }
}

/* the contour rows' Jacobian dF/dq, (2k) x n_q */
static void jacobian(const mm_model *m, const term_value *t, double *J)
{
    const mm_program *p = m->program;
    int nq = p->n_q;
    memset(J, 0, sizeof(double) * 2 * p->n_contours * nq);
    for (int i = 0; i < p->n_terms; ++i) {
        const int *f = p->terms + MM_TERM_FIELDS * i;
        if (f[0] >= p->n_contours) continue;
        double *jx = J + 2 * f[0] * nq, *jy = jx + nq;
        double coef = m->registers[f[1]];
        if (f[2] >= 0) { jx[f[2]] += coef * t[i].c; jy[f[2]] += coef * t[i].s; }
        if (f[3] >= 0) { jx[f[3]] -= t[i].L * t[i].s; jy[f[3]] += t[i].L * t[i].c; }
    }
}

/* the contour equations F(q) (rows x1, y1, x2, y2, ...), m */
static void residual(const mm_model *m, const term_value *t, double *F)
{
    const mm_program *p = m->program;
    memset(F, 0, sizeof(double) * 2 * p->n_contours);
    for (int i = 0; i < p->n_terms; ++i) {
        int c = p->terms[MM_TERM_FIELDS * i];
        if (c >= p->n_contours) continue;
        F[2 * c] += t[i].L * t[i].c;
        F[2 * c + 1] += t[i].L * t[i].s;
    }
}

static double residual_max(const mm_model *m, const term_value *t)
{
    const mm_program *p = m->program;
    double F[MAX_Q];
    residual(m, t, F);
    double worst = 0.0;
    for (int i = 0; i < 2 * p->n_contours; ++i) {
        if (!(fabs(F[i]) <= worst)) worst = fabs(F[i]);     /* a NaN wins */
    }
    return worst;
}

/* the unknowns' columns of J (dropping phi1's), (n_q-1) x (n_q-1) */
static void unknown_block(int nq, const double *J, double *Ju)
{
    int n = nq - 1;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) Ju[i * n + j] = J[i * nq + j + 1];
}

static int newton(mm_model *m, double *q)
{
    const mm_program *p = m->program;
    int nq = p->n_q, n = nq - 1;
    double tol = 1e-13 * m->length_scale;
    term_value t[256];
    double J[MAX_Q * MAX_Q], Ju[MAX_Q * MAX_Q], F[MAX_Q];
    for (int it = 0; it < 50; ++it) {
        terms_at(m, q, t);
        if (residual_max(m, t) <= tol) return MM_OK;
        residual(m, t, F);
        jacobian(m, t, J);
        unknown_block(nq, J, Ju);
        if (!solve(n, Ju, F)) return MM_NO_CONVERGENCE;
        for (int j = 0; j < n; ++j) q[j + 1] -= F[j];
    }
    terms_at(m, q, t);
    return residual_max(m, t) <= 1e3 * tol ? MM_OK : MM_NO_CONVERGENCE;
}

/* the contours' Jacobian J (2k x n_q) at the terms t and the LU factors of its unknowns' block Ju
 * (pivots piv); the signed conditioning into *cond (may be NULL): the det of the column-normalised
 * block, 1 for orthogonal columns, 0 at a dead point, det(Ju D) = det(Ju) prod D from the same
 * factors as the solves. MM_SINGULAR where Ju is singular; n_q = 1 (no unknown) is regular. */
static int factor_unknowns(const mm_model *m, const term_value *t, double *J, double *Ju, int *piv, double *cond)
{
    int nq = m->program->n_q, n = nq - 1;
    jacobian(m, t, J);
    unknown_block(nq, J, Ju);
    if (n == 0) { if (cond) *cond = 1.0; return MM_OK; }
    double norms = 1.0;
    if (cond) {
        for (int j = 0; j < n; ++j) {
            double norm = 0.0;
            for (int i = 0; i < n; ++i) norm += Ju[i * n + j] * Ju[i * n + j];
            norms *= sqrt(norm);
        }
    }
    double det;
    int regular = lu_factor(n, Ju, piv, &det);
    if (cond) *cond = det / norms;
    return regular ? MM_OK : MM_SINGULAR;
}

/* q', q'' at solved positions (their terms t); the signed conditioning into *cond (may be NULL) */
static int transfer(const mm_model *m, const term_value *t, double *dq, double *ddq, double *cond)
{
    const mm_program *p = m->program;
    int nq = p->n_q, n = nq - 1, k = p->n_contours;
    double J[MAX_Q * MAX_Q], Ju[MAX_Q * MAX_Q], rhs[2 * MAX_Q];
    int piv[MAX_Q];
    int status = factor_unknowns(m, t, J, Ju, piv, cond);
    dq[0] = 1.0;
    ddq[0] = 0.0;
    if (n == 0 || status) return status;
    for (int i = 0; i < n; ++i) rhs[i] = -J[i * nq];
    lu_solve(n, Ju, piv, rhs);
    for (int j = 0; j < n; ++j) dq[j + 1] = rhs[j];
    double quad[MAX_Q];
    memset(quad, 0, sizeof quad);
    for (int i = 0; i < p->n_terms; ++i) {
        const int *f = p->terms + MM_TERM_FIELDS * i;
        if (f[0] >= k) continue;
        double coef = m->registers[f[1]];
        double dL = f[2] >= 0 ? coef * dq[f[2]] : 0.0;
        double dth = f[3] >= 0 ? dq[f[3]] : 0.0;
        double along = -t[i].L * dth * dth, across = 2.0 * dL * dth;
        quad[2 * f[0]] -= along * t[i].c - across * t[i].s;
        quad[2 * f[0] + 1] -= along * t[i].s + across * t[i].c;
    }
    lu_solve(n, Ju, piv, quad);
    for (int j = 0; j < n; ++j) ddq[j + 1] = quad[j];
    return MM_OK;
}

/* the closed form's positions at phi1 (its angles as the expressions give them) */
static int closed_positions(mm_model *m, double phi1, double *q)
{
    const mm_program *p = m->program;
    double *r = m->registers;
    r[p->phi1] = phi1;
    run(p, r, MM_CLOSED);
    q[0] = phi1;
    for (int j = 1; j < p->n_q; ++j) {
        q[j] = r[p->kinematics + 3 * (j - 1)];
        if (!isfinite(q[j])) return MM_NO_SOLUTION;
    }
    return MM_OK;
}

/* move each angle to the continuous branch: the turn table's nearest value plus whole turns */
static void count_turns(const mm_model *m, double *q)
{
    const mm_program *p = m->program;
    if (!m->have_turn) return;
    double rel = q[0] - m->turn_start;
    double turns = floor(rel / TWO_PI);
    double at = (rel - TWO_PI * turns) * (MM_TURN_POINTS / TWO_PI) + 0.5;
    long nearest = isfinite(at) ? (long)at : 0;
    if (nearest < 0) nearest = 0;
    if (nearest > MM_TURN_POINTS) nearest = MM_TURN_POINTS;
    const double *row = m->turn + nearest * p->n_q;
    for (int j = 1; j < p->n_q; ++j) {
        if (!p->angle_column[j]) continue;
        double near = row[j] + TWO_PI * turns * m->winding[j];
        q[j] += TWO_PI * nearbyint((near - q[j]) / TWO_PI);
    }
}

/* positions by Newton's method from the turn table's nearest entry */
static int newton_positions(mm_model *m, double phi1, double *q)
{
    const mm_program *p = m->program;
    int nq = p->n_q;
    double h = TWO_PI / MM_TURN_POINTS;
    double rel = fmod(phi1 - m->turn_start, TWO_PI);
    if (rel < 0) rel += TWO_PI;
    if (!isfinite(rel)) return MM_NO_CONVERGENCE;
    long i = lrint(rel / h);
    if (i < 0) i = 0;
    if (i > MM_TURN_POINTS) i = MM_TURN_POINTS;
    double dphi = rel - i * h;
    const double *base = m->turn + i * nq;
    double dq[MAX_Q], ddq[MAX_Q];
    term_value t[256];
    terms_at(m, base, t);
    int status = transfer(m, t, dq, ddq, NULL);
    if (status) return status;
    for (int j = 0; j < nq; ++j) q[j] = base[j] + dphi * dq[j] + 0.5 * dphi * dphi * ddq[j];
    q[0] = phi1;
    return newton(m, q);
}

static int positions(mm_model *m, double phi1, double *q)
{
    int status = m->program->closed_form ? closed_positions(m, phi1, q) : newton_positions(m, phi1, q);
    if (status == MM_OK) count_turns(m, q);
    return status;
}

/* the turn table: a closed form's positions on the turn, unwrapped; or the continuation */
static int build_turn(mm_model *m)
{
    const mm_program *p = m->program;
    int nq = p->n_q;
    double h = TWO_PI / MM_TURN_POINTS;
    m->have_turn = 0;
    if (p->closed_form) {
        m->turn_start = 0.0;
        for (int i = 0; i <= MM_TURN_POINTS; ++i) {
            int status = closed_positions(m, i * h, m->turn + i * nq);
            if (status) { m->error_angle = i * h; return status; }
            if (i == 0) continue;
            for (int j = 1; j < nq; ++j) {
                if (!p->angle_column[j]) continue;
                double *now = m->turn + i * nq + j, before = now[-nq];
                *now += TWO_PI * nearbyint((before - *now) / TWO_PI);     /* numpy.unwrap's rule */
            }
        }
    } else {
        double *q = m->turn;
        const double *g = m->registers + p->guess;
        for (int j = 0; j < nq; ++j) q[j] = g[j];
        m->turn_start = g[0];
        int status = newton(m, q);
        if (status) { m->error_angle = g[0]; return MM_GUESS; }
        double dq[MAX_Q], ddq[MAX_Q];
        term_value t[256];
        for (int i = 1; i <= MM_TURN_POINTS; ++i) {
            double *prev = m->turn + (i - 1) * nq, *next = prev + nq;
            terms_at(m, prev, t);
            status = transfer(m, t, dq, ddq, NULL);
            if (status) { m->error_angle = prev[0]; return status; }
            for (int j = 0; j < nq; ++j) next[j] = prev[j] + h * dq[j] + 0.5 * h * h * ddq[j];
            next[0] = m->turn_start + i * h;
            if (newton(m, next)) { m->error_angle = next[0]; return MM_LOST; }
        }
        const double *first = m->turn, *last = m->turn + MM_TURN_POINTS * nq;
        for (int j = 1; j < nq; ++j) {
            double delta = last[j] - first[j];
            if (p->angle_column[j]) delta = delta - TWO_PI * floor((delta + 3.141592653589793) / TWO_PI);
            if (fabs(delta) > 1e-8 * fmax(1.0, m->length_scale)) {
                m->error_angle = last[0];
                m->error_index = j;
                return MM_BRANCH;
            }
        }
    }
    const double *first = m->turn, *last = m->turn + MM_TURN_POINTS * nq;
    for (int j = 0; j < nq; ++j)
        m->winding[j] = p->angle_column[j] ? nearbyint((last[j] - first[j]) / TWO_PI) : 0.0;
    m->have_turn = 1;
    return MM_OK;
}

/* kinematics into the registers; the signed conditioning into *cond and the contours' largest
 * residual at the positions found into *residual_out (each may be NULL) */
static int kinematics_of(mm_model *m, double phi1, const double *q, double *cond, double *residual_out);

static int kinematics_at(mm_model *m, double phi1, double *cond, double *residual_out)
{
    double q[MAX_Q];
    int status = positions(m, phi1, q);
    if (status) { m->error_angle = phi1; return status; }
    return kinematics_of(m, phi1, q, cond, residual_out);
}

/* kinematics_at from the positions q at phi1 */
static int kinematics_of(mm_model *m, double phi1, const double *q, double *cond, double *residual_out)
{
    const mm_program *p = m->program;
    double *r = m->registers;
    int nq = p->n_q;
    double dq[MAX_Q], ddq[MAX_Q];
    term_value t[256];
    int status;
    terms_at(m, q, t);
    if (residual_out) *residual_out = residual_max(m, t);
    status = transfer(m, t, dq, ddq, cond);
    if (status) { m->error_angle = phi1; return status; }
    r[p->phi1] = phi1;
    double *u = r + p->kinematics;
    for (int j = 1; j < nq; ++j) { u[0] = q[j]; u[1] = dq[j]; u[2] = ddq[j]; u += 3; }
    /* the points: chain sums of the terms and of their derivatives */
    for (int c = p->n_contours; c < p->n_chains; ++c) {
        double *pt = r + p->kinematics + 3 * (nq - 1) + 6 * (c - p->n_contours);
        const int *cc = p->chain_constants + 2 * c;
        pt[0] = cc[0] >= 0 ? r[cc[0]] : 0.0;
        pt[1] = cc[1] >= 0 ? r[cc[1]] : 0.0;
        pt[2] = pt[3] = pt[4] = pt[5] = 0.0;
    }
    for (int i = 0; i < p->n_terms; ++i) {
        const int *f = p->terms + MM_TERM_FIELDS * i;
        if (f[0] < p->n_contours) continue;
        double *pt = r + p->kinematics + 3 * (nq - 1) + 6 * (f[0] - p->n_contours);
        double coef = r[f[1]];
        double L = t[i].L, c = t[i].c, s = t[i].s;
        double dL = f[2] >= 0 ? coef * dq[f[2]] : 0.0, ddL = f[2] >= 0 ? coef * ddq[f[2]] : 0.0;
        double dth = f[3] >= 0 ? dq[f[3]] : 0.0, ddth = f[3] >= 0 ? ddq[f[3]] : 0.0;
        double along = ddL - L * dth * dth, across = L * ddth + 2.0 * dL * dth;
        pt[0] += L * c;
        pt[1] += L * s;
        pt[2] += dL * c - L * dth * s;
        pt[3] += dL * s + L * dth * c;
        pt[4] += along * c - across * s;
        pt[5] += along * s + across * c;
    }
    return MM_OK;
}

static int kinematics(mm_model *m, double phi1, double *cond)
{
    return kinematics_at(m, phi1, cond, NULL);
}

int mm_evaluate(mm_model *m, double phi1)
{
    int status = kinematics(m, phi1, NULL);
    if (status == MM_OK) run(m->program, m->registers, MM_ROWS);
    return status;
}

/* ------------------------------------------------------------------------------ binding */
/* the per-angle registers phi1 .. the last point's: what a scan angle's kinematics leave */
static int kinematics_width(const mm_program *p)
{
    return p->kinematics - p->phi1 + 3 * (p->n_q - 1) + 6 * p->n_points;
}

void mm_free(mm_model *m)
{
    free(m->registers);
    free(m->turn);
    free(m->winding);
    free(m->forces);
    free(m->scan);
    free(m->coordinate_winding);
    free(m->reaction_kept);
    m->registers = m->turn = m->winding = m->forces = m->scan = m->coordinate_winding = NULL;
    m->reaction_kept = NULL;
}

int mm_bind(mm_model *m, const mm_program *p, const double *parameters, int n_parameters)
{
    memset(m, 0, sizeof *m);
    m->program = p;
    if (p->n_q > MAX_Q || p->n_terms > 256 || p->n_angles > 256 || p->n_links > MAX_LINKS ||
        2 * p->n_joints * p->n_terms_reaction > 2 * 3 * MAX_LINKS * 64 || p->n_q != 1 + 2 * p->n_contours) return MM_NO_MEMORY;
    m->registers = calloc((size_t)p->n_registers, sizeof(double));
    m->turn = malloc(sizeof(double) * (MM_TURN_POINTS + 1) * p->n_q);
    m->winding = calloc((size_t)p->n_q, sizeof(double));
    m->forces = calloc((size_t)2 * (p->n_columns > 0 ? p->n_columns : 1) * MM_MAX_SWITCHES, sizeof(double));
    m->scan = malloc(sizeof(double) * (MM_SCAN_POINTS / 2) * kinematics_width(p));
    if (!m->registers || !m->turn || !m->winding || !m->forces || !m->scan) return MM_NO_MEMORY;
    memcpy(m->registers, parameters, sizeof(double) * n_parameters);
    run(p, m->registers, MM_SETUP);
    for (int i = 0; i < p->n_checks; ++i) {
        double v = m->registers[p->checks[i]];
        if (!(isfinite(v) && v >= 0.0)) {
            m->error_index = i;
            m->error_value = v;
            return MM_CHECK;
        }
    }
    double scale = 0.0;
    for (int i = 0; i < p->n_terms; ++i) scale = fmax(scale, fabs(m->registers[p->terms[MM_TERM_FIELDS * i + 1]]));
    m->length_scale = p->n_terms ? scale : 1.0;
    int status = build_turn(m);
    /* a closed form with no solution somewhere: the assembly check's finer scan finds the first
     * angle (the engine's order: the scan's positions before the turn table's) */
    if (status != MM_OK && p->closed_form) {
        m->have_turn = 0;
        return MM_OK;
    }
    return status;
}

/* ----------------------------------------------------------------------- assembly and searches */

static int scan_angle(mm_model *m, double phi1, int turn_row, int full, double *cond, double *residual);

/* the signed conditioning at phi1 (the positions, not their derivatives) */
static int conditioning_at(mm_model *m, double phi1, double *cond)
{
    double residual;
    return scan_angle(m, phi1, -1, 0, cond, &residual);
}

/* the root of the conditioning between a and b (signs differ), by bisection */
static double dead_point(mm_model *m, double a, double b, double fa)
{
    for (int it = 0; it < 60 && b - a > 1e-15; ++it) {
        double c = 0.5 * (a + b), fc;
        if (conditioning_at(m, c, &fc)) break;
        if (signbit(fc) == signbit(fa)) { a = c; fa = fc; } else b = c;
    }
    return 0.5 * (a + b);
}

/* the signed conditioning at solved positions (their terms t): transfer's, without its solves */
static int conditioning_of(const mm_model *m, const term_value *t, double *cond)
{
    double J[MAX_Q * MAX_Q], Ju[MAX_Q * MAX_Q];
    int piv[MAX_Q];
    return factor_unknowns(m, t, J, Ju, piv, cond);
}

/* one angle of the assembly scan: its residual and signed conditioning, and with ``full`` its
 * kinematics in the registers (what the searches start from). A closed form's positions at one of
 * the turn table's own angles are that table's row, bit for bit what positions() gives there
 * (the same closed form at the same angle, moved by the same whole turns): not computed again. */
static int scan_angle(mm_model *m, double phi1, int turn_row, int full, double *cond, double *residual)
{
    const mm_program *p = m->program;
    double q[MAX_Q];
    if (turn_row >= 0 && p->closed_form && m->have_turn && m->turn_start == 0.0)
        memcpy(q, m->turn + (size_t)turn_row * p->n_q, sizeof(double) * p->n_q);
    else {
        int status = positions(m, phi1, q);
        if (status) { m->error_angle = phi1; return status; }
    }
    if (full) return kinematics_of(m, phi1, q, cond, residual);
    term_value t[256];
    terms_at(m, q, t);
    *residual = residual_max(m, t);
    int status = conditioning_of(m, t, cond);
    if (status) m->error_angle = phi1;
    return status;
}

/* q' at positions q (raw or unwrapped: whole turns do not change it) into dq */
static int rates_at(const mm_model *m, const double *q, double *dq)
{
    double ddq[MAX_Q];
    term_value t[256];
    terms_at(m, q, t);
    return transfer(m, t, dq, ddq, NULL);
}

/* the largest trapezoid miss |q(b) - q(a) - (b - a) (q'(a) + q'(b)) / 2| of column j over n intervals
 * of angles x with positions q and rates dq (rows of n_q); its interval into *at */
static double worst_miss(int nq, int j, int n, const double *x, const double *q, const double *dq, int *at)
{
    double worst = -1.0;
    for (int i = 0; i < n; ++i) {
        double miss = fabs(q[(i + 1) * nq + j] - q[i * nq + j] - 0.5 * (x[i + 1] - x[i]) * (dq[i * nq + j] + dq[(i + 1) * nq + j]));
        if (miss > worst || isnan(miss)) { worst = miss; *at = i; if (isnan(miss)) break; }
    }
    return worst;
}

/* A closed form's unknown that jumps along the turn though the contours close and the conditioning
 * keeps its sign (two loops' branches swapped at one angle): the engine's rule
 * (Contour._refuse_jumps), the check's last. Each unknown's increment between neighbouring turn
 * table angles against the trapezoid rule on its transfer function; the worst interval refined on
 * 65 angles until its miss closes (a steep but continuous function: it shrinks as h^3) or keeps
 * its gap however fine (a jump). The rates at the table's angles are the scan's where it kept
 * them (every other scan angle is a turn table angle), computed where it did not (coarse). */
static int refuse_jumps(mm_model *m, int coarse)
{
    const mm_program *p = m->program;
    const int nq = p->n_q, rows = MM_TURN_POINTS + 1, width = kinematics_width(p);
    const double h = TWO_PI / MM_TURN_POINTS;
    double *x = malloc(sizeof(double) * rows), *dq = malloc(sizeof(double) * rows * nq);
    int status = (x && dq) ? MM_OK : MM_NO_MEMORY;
    for (int i = 0; i < rows && status == MM_OK; ++i) {
        x[i] = i * h;
        if (!coarse && i < MM_TURN_POINTS) {
            const double *kept = m->scan + (size_t)i * width + (p->kinematics - p->phi1);
            dq[i * nq] = 1.0;
            for (int j = 1; j < nq; ++j) dq[i * nq + j] = kept[3 * (j - 1) + 1];
        } else if ((status = rates_at(m, m->turn + (size_t)i * nq, dq + i * nq)))
            m->error_angle = x[i];
    }
    for (int j = 1; j < nq && status == MM_OK; ++j) {
        double scale = p->angle_column[j] ? TWO_PI : fmax(m->length_scale, 1e-300);
        int i;
        double gaps[4], lo, hi, gap = 0.0;
        gaps[0] = worst_miss(nq, j, MM_TURN_POINTS, x, m->turn, dq, &i);
        lo = x[i];
        hi = x[i + 1];
        int n_gaps = 1, closed = 0;
        for (int it = 0; it < 3 && status == MM_OK; ++it) {
            double last = gaps[n_gaps - 1];
            if (last <= 1e-3 * scale || (n_gaps > 1 && last < 0.25 * gaps[n_gaps - 2])) { closed = 1; break; }
            double fine[65], q[65 * MAX_Q], fine_dq[65 * MAX_Q];
            for (int k = 0; k < 65 && status == MM_OK; ++k) {
                fine[k] = k == 64 ? hi : lo + k * ((hi - lo) / 64.0);
                double *row = q + k * nq;
                if ((status = closed_positions(m, fine[k], row)) == MM_OK) status = rates_at(m, row, fine_dq + k * nq);
                if (status) { m->error_angle = fine[k]; break; }
                for (int c = 1; c < nq && k > 0; ++c)          /* unwrapped along the fine angles */
                    if (p->angle_column[c]) row[c] += TWO_PI * nearbyint((row[c - nq] - row[c]) / TWO_PI);
            }
            if (status) break;
            gaps[n_gaps++] = worst_miss(nq, j, 64, fine, q, fine_dq, &i);
            lo = fine[i];
            hi = fine[i + 1];
            gap = q[(i + 1) * nq + j] - q[i * nq + j];
        }
        if (status == MM_OK && !closed) {
            m->error_index = j;
            m->error_value = gap;
            m->error_angle = lo;
            status = MM_JUMPS;
        }
    }
    free(x);
    free(dq);
    return status;
}

/* coarse: every 0.5 deg instead of 0.25 (the bisection for a geometry's bound, as the engine's) */
static int check_assembly(mm_model *m, int coarse)
{
    const mm_program *p = m->program;
    const int points = coarse ? MM_SCAN_POINTS / 2 : MM_SCAN_POINTS;
    double h = TWO_PI / points;
    double *signed_ = malloc(sizeof(double) * (points + 1));
    if (!signed_) return MM_NO_MEMORY;
    double residual = 0.0;
    int status = MM_OK;
    int width = kinematics_width(p);
    /* the turn table's angles are every MM_TURN_POINTS-th of the turn: every other scan angle */
    const int per_row = points / MM_TURN_POINTS;
    for (int i = 0; i < points && status == MM_OK; ++i) {
        /* with the residual of the positions found (a closed form must satisfy the contours) */
        double res;
        int kept = !coarse && i % 2 == 0;          /* every other scan angle: where the searches start */
        status = scan_angle(m, i * h, i % per_row == 0 ? i / per_row : -1, kept, signed_ + i, &res);
        if (status) break;
        if (kept) memcpy(m->scan + (i / 2) * width, m->registers + p->phi1, sizeof(double) * width);
        if (!(res <= residual)) residual = res;
    }
    if (status) { free(signed_); return status; }
    if (!(residual <= 1e-9 * m->length_scale)) {
        m->error_value = residual;
        free(signed_);
        return MM_CLOSED_FORM;
    }
    signed_[points] = signed_[0];
    for (int i = 0; i < points; ++i)
        if (signbit(signed_[i]) != signbit(signed_[i + 1])) {
            m->error_angle = dead_point(m, i * h, (i + 1) * h, signed_[i]);
            free(signed_);
            return MM_DEAD_POINT;
        }
    int worst = 0;
    for (int i = 1; i < points; ++i)
        if (fabs(signed_[i]) < fabs(signed_[worst])) worst = i;
    double worst_value = fabs(signed_[worst]), worst_angle = worst * h;
    /* a lock can hide between two scan angles: refine on 65 angles around the smallest */
    double near[65], prev = 0.0;
    for (int i = 0; i < 65; ++i) {
        double a = worst * h - h + i * (2.0 * h / 64.0);
        if ((status = conditioning_at(m, a, near + i))) { free(signed_); return status; }
        if (i > 0 && signbit(near[i]) != signbit(prev)) {
            m->error_angle = dead_point(m, a - 2.0 * h / 64.0, a, prev);
            free(signed_);
            return MM_DEAD_POINT;
        }
        prev = near[i];
        if (fabs(near[i]) < worst_value) { worst_value = fabs(near[i]); worst_angle = a; }
    }
    free(signed_);
    m->worst_conditioning = worst_value;
    m->worst_angle = worst_angle;
    if (worst_value < p->min_conditioning) {
        m->error_angle = worst_angle;
        m->error_value = worst_value;
        return MM_LOCKS;
    }
    return p->closed_form ? refuse_jumps(m, coarse) : MM_OK;
}

/* the value a search section gives at phi1 */
static int quantity(mm_model *m, int section, double phi1, double *value)
{
    int status = kinematics(m, phi1, NULL);
    if (status) return status;
    run(m->program, m->registers, section);
    *value = m->registers[m->program->sections[2 * section + 1] > 0
                          ? m->program->code[5 * (m->program->sections[2 * section + 1] - 1) + 1] : 0];
    return MM_OK;
}

/* where the section's value crosses level over the turn: (angle, rising) appended to roots
 * (sign changes on 720 angles, then the secant kept in its bracket, as numerics.bracketed_roots) */
static int crossings(mm_model *m, int section, double level, double *roots, int *rising, int *n_roots, int max_roots)
{
    enum { N = 720 };
    double v[N + 1], h = TWO_PI / N;
    int status;
    double scale = 0.0;
    const mm_program *p = m->program;
    int width = kinematics_width(p);
    int last = p->code[5 * (p->sections[2 * section + 1] - 1) + 1];
    for (int i = 0; i < N; ++i) {
        /* the scan's kinematics at these angles, kept by the assembly check */
        memcpy(m->registers + p->phi1, m->scan + i * width, sizeof(double) * width);
        run(p, m->registers, section);
        v[i] = m->registers[last];
        scale = fmax(scale, fabs(v[i]));
    }
    v[N] = v[0];
    double ftol = 16.0 * DBL_EPSILON * scale;
    for (int i = 0; i < N; ++i) {
        double fa = v[i] - level, fb = v[i + 1] - level;
        if (!(fa == 0.0 || fa * fb < 0.0)) continue;
        double a = i * h, b = (i + 1) * h, root = (fa == 0.0) ? a : b;
        if (fa != 0.0 && fb != 0.0) {
            double x0 = a, f0 = fa, x1 = b, f1 = fb;
            for (int it = 0; it < 100; ++it) {
                double lo = fmin(a, b), hi = fmax(a, b);
                double c = x1 - f1 * (x1 - x0) / (f1 - f0);
                if (!(c >= lo && c <= hi)) c = 0.5 * (lo + hi);
                double fc;
                if ((status = quantity(m, section, c, &fc))) return status;
                fc -= level;
                if (fc * fa < 0.0) { b = c; fb = fc; } else { a = c; fa = fc; }
                double step = fabs(c - x1);
                x0 = x1; f0 = f1; x1 = c; f1 = fc;
                root = c;
                double tol = 2.0 * 1e-15 * fabs(c) + 1e-15;
                if (!(fabs(fc) > ftol && step > 0.5 * tol && fabs(b - a) > tol)) break;
            }
        }
        if (*n_roots >= max_roots) return MM_TOO_MANY_SWITCHES;
        roots[*n_roots] = fmod(root, TWO_PI);
        rising[*n_roots] = v[i + 1] > level;
        ++*n_roots;
    }
    return MM_OK;
}

static int compare(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int add_switch(mm_model *m, double angle)
{
    /* angles closer than 1e-13 rad are one switch (a band level is met once per direction) */
    angle = nearbyint(fmod(angle, TWO_PI) * 1e13) / 1e13;
    for (int i = 0; i < m->n_switches; ++i)
        if (m->switches[i] == angle) return MM_OK;
    if (m->n_switches >= MM_MAX_SWITCHES) return MM_TOO_MANY_SWITCHES;
    m->switches[m->n_switches++] = angle;
    return MM_OK;
}

static int searches(mm_model *m)
{
    const mm_program *p = m->program;
    double *r = m->registers;
    m->n_switches = 0;
    for (int s = 0; s < p->n_searches; ++s) {
        const int *f = p->searches + MM_SEARCH_FIELDS * s;
        double roots[MM_MAX_SWITCHES];
        int rising[MM_MAX_SWITCHES], n = 0, status;
        m->error_index = s;
        if (f[0] == MM_BAND) {
            double low = r[f[3]], high = r[f[4]], stroke = high - low;
            double levels[4] = {low + r[f[5]] * stroke, low + r[f[6]] * stroke,
                                high - r[f[5]] * stroke, high - r[f[6]] * stroke};
            qsort(levels, 4, sizeof(double), compare);
            for (int k = 0; k < 4; ++k) {
                if (k > 0 && levels[k] == levels[k - 1]) continue;
                if ((status = crossings(m, f[1], levels[k], roots, rising, &n, MM_MAX_SWITCHES))) return status;
            }
            for (int k = 0; k < n; ++k)
                if ((status = add_switch(m, roots[k]))) return status;
            continue;
        }
        if ((status = crossings(m, f[1], 0.0, roots, rising, &n, MM_MAX_SWITCHES))) return status;
        if (f[0] == MM_ROCKER) {
            int rises = 0, falls = 0;
            double rise = 0.0, fall = 0.0;
            for (int k = 0; k < n; ++k) {
                if (rising[k]) { ++rises; rise = roots[k]; } else { ++falls; fall = roots[k]; }
            }
            if (rises != 1 || falls != 1) { m->error_value = n; return MM_NOT_ROCKER; }
            r[f[3]] = rise;
            r[f[4]] = fall;
            continue;
        }
        if (n == 0) return MM_NO_REVERSAL;
        for (int k = 0; k < n; ++k)
            if ((status = add_switch(m, roots[k]))) return status;
        if (f[3] >= 0) {
            double low = INFINITY, high = -INFINITY;
            for (int k = 0; k < n; ++k) {
                double x;
                if ((status = quantity(m, f[2], roots[k], &x))) return status;
                low = fmin(low, x);
                high = fmax(high, x);
            }
            r[f[3]] = low;
            r[f[4]] = high;
        }
    }
    m->error_index = 0;
    qsort(m->switches, m->n_switches, sizeof(double), compare);
    /* the switched loads' values on each interval, for each direction of the crank */
    int nc = p->n_columns;
    for (int k = 0; k < m->n_switches; ++k) {
        double next = k + 1 < m->n_switches ? m->switches[k + 1] : m->switches[0] + TWO_PI;
        double mid = fmod(0.5 * (m->switches[k] + next), TWO_PI);
        int status = kinematics(m, mid, NULL);
        if (status) return status;
        for (int d = 0; d < 2; ++d) {
            r[p->omega1] = d == 0 ? 1.0 : -1.0;
            run(p, r, MM_VALUES);
            for (int c = 0; c < nc; ++c) m->forces[(k * 2 + d) * nc + c] = r[p->columns[c]];
        }
    }
    return MM_OK;
}

int mm_check(mm_model *m, int coarse)
{
    return check_assembly(m, coarse);
}

int mm_prepare(mm_model *m)
{
    int status = check_assembly(m, 0);
    if (status == MM_OK) status = searches(m);
    return status;
}

int mm_rows(const mm_model *m, int table)
{
    const mm_program *p = m->program;
    if (table == MM_TABLE_QUANTITIES) return 3 * p->n_coordinates;
    if (table == MM_TABLE_REACTIONS) return 2 * p->n_joints * p->n_terms_reaction;
    return p->n_rows;
}

/* a point's registers (x, y, dx, dy, ddx, ddy) */
static const double *point_registers(const mm_model *m, int point)
{
    const mm_program *p = m->program;
    return m->registers + p->kinematics + 3 * (p->n_q - 1) + 6 * point;
}

/* every joint reaction's terms at phi1 (dynamics/reactions.py, one term at a time as
 * tabulated.tabulate_reactions): out[component * terms + term] */
static int reactions_at(mm_model *m, double phi1, double *out)
{
    const mm_program *p = m->program;
    const double *r = m->registers;
    int status = kinematics(m, phi1, NULL);
    if (status) return status;
    run(p, m->registers, MM_REACTIONS);
    int size = 3 * p->n_links, nt = p->n_terms_reaction;
    double A[(3 * MAX_LINKS) * (3 * MAX_LINKS)], b[3 * MAX_LINKS];
    int piv[3 * MAX_LINKS];
    memset(A, 0, sizeof(double) * size * size);
    /* a unit of unknown col as the force (fx, fy) at (px, py) on link */
#define ADD_FORCE(link, col, px, py, fx, fy)                                                   \
    do {                                                                                         \
        if ((link) >= 0) {                                                                       \
            const double *c_ = point_registers(m, p->links[5 * (link)]);                         \
            double *row_ = A + 3 * (link) * size;                                                \
            row_[(col)] += (fx);                                                                 \
            row_[size + (col)] += (fy);                                                          \
            row_[2 * size + (col)] += ((px) - c_[0]) * (fy) - ((py) - c_[1]) * (fx);             \
        }                                                                                        \
    } while (0)
    for (int k = 0; k < p->n_joints; ++k) {
        const int *j = p->joints + 5 * k;
        const double *at = point_registers(m, j[1]);
        int col = 2 * k;
        if (!j[0]) {
            ADD_FORCE(j[3], col, at[0], at[1], 1.0, 0.0);
            ADD_FORCE(j[2], col, at[0], at[1], -1.0, -0.0);
            ADD_FORCE(j[3], col + 1, at[0], at[1], 0.0, 1.0);
            ADD_FORCE(j[2], col + 1, at[0], at[1], -0.0, -1.0);
        } else {
            double nx = -sin(r[j[4]]), ny = cos(r[j[4]]);
            ADD_FORCE(j[3], col, at[0], at[1], nx, ny);
            ADD_FORCE(j[2], col, at[0], at[1], -nx, -ny);
            if (j[3] >= 0) A[(3 * j[3] + 2) * size + col + 1] += 1.0;
            if (j[2] >= 0) A[(3 * j[2] + 2) * size + col + 1] -= 1.0;
        }
    }
#undef ADD_FORCE
    A[(3 * p->crank + 2) * size + size - 1] = 1.0;
    double det;
    if (!lu_factor(size, A, piv, &det)) { m->error_angle = phi1; return MM_SINGULAR; }
    for (int t = 0; t < nt; ++t) {
        memset(b, 0, sizeof(double) * size);
        double eps = p->term_inertia[2 * t], w2 = p->term_inertia[2 * t + 1];
        if (eps != 0.0 || w2 != 0.0)
            for (int l = 0; l < p->n_links; ++l) {
                const int *link = p->links + 5 * l;
                const double *c = point_registers(m, link[0]);
                double mass = r[link[1]], inertia = r[link[2]];
                b[3 * l] += mass * (eps * c[2] + w2 * c[4]);
                b[3 * l + 1] += mass * (eps * c[3] + w2 * c[5]);
                b[3 * l + 2] += inertia * (eps * r[link[3]] + w2 * r[link[4]]);
            }
        for (int i = 0; i < p->n_applied; ++i) {
            const int *f = p->applied + 6 * i;
            if (f[0] != t) continue;
            int l = f[1];
            const double *c = point_registers(m, p->links[5 * l]);
            double fx = f[3] >= 0 ? r[f[3]] : 0.0, fy = f[4] >= 0 ? r[f[4]] : 0.0, mz = f[5] >= 0 ? r[f[5]] : 0.0;
            b[3 * l] -= fx;
            b[3 * l + 1] -= fy;
            b[3 * l + 2] -= mz;
            if (f[2] >= 0) {
                const double *at = point_registers(m, f[2]);
                b[3 * l + 2] -= (at[0] - c[0]) * fy - (at[1] - c[1]) * fx;
            }
        }
        lu_solve(size, A, piv, b);
        for (int k = 0; k < 2 * p->n_joints; ++k) out[k * nt + t] = b[k];
    }
    return MM_OK;
}

/* which reaction terms a component has: the others are zero up to the solve's round-off, and
 * exactly zero in the table (tabulated.tabulate_reactions' probe of 96 angles) */
static int reaction_mask(mm_model *m)
{
    const mm_program *p = m->program;
    int nc = 2 * p->n_joints, nt = p->n_terms_reaction;
    if (m->have_reaction_mask) return MM_OK;
    double *largest = calloc((size_t)nc * nt, sizeof(double)), *term_largest = calloc((size_t)nt, sizeof(double));
    double *x = malloc(sizeof(double) * nc * nt);
    m->reaction_kept = malloc(sizeof(int) * nc * nt);
    int status = (largest && term_largest && x && m->reaction_kept) ? MM_OK : MM_NO_MEMORY;
    for (int i = 0; i < 96 && status == MM_OK; ++i) {
        status = reactions_at(m, i * (TWO_PI / 96), x);
        for (int k = 0; k < nc * nt && status == MM_OK; ++k) {
            largest[k] = fmax(largest[k], fabs(x[k]));
            term_largest[k % nt] = fmax(term_largest[k % nt], fabs(x[k]));
        }
    }
    for (int k = 0; k < nc * nt && status == MM_OK; ++k)
        m->reaction_kept[k] = largest[k] > 1e-12 * term_largest[k % nt];
    if (status == MM_OK) m->have_reaction_mask = 1;
    free(largest); free(term_largest); free(x);
    return status;
}

/* whole turns per crank turn of each angle coordinate (tabulated.tabulate_quantities: its
 * increments on 512 intervals, each taken in (-pi, pi]) */
static int coordinate_winding(mm_model *m)
{
    const mm_program *p = m->program;
    if (m->have_quantity_winding) return MM_OK;
    int nc = p->n_coordinates;
    double *previous = malloc(sizeof(double) * (nc + 1)), *sum = calloc((size_t)nc + 1, sizeof(double));
    m->coordinate_winding = calloc((size_t)nc + 1, sizeof(double));
    if (!previous || !sum || !m->coordinate_winding) { free(previous); free(sum); return MM_NO_MEMORY; }
    for (int i = 0; i <= 512; ++i) {
        int status = kinematics(m, i * (TWO_PI / 512), NULL);
        if (status) { free(previous); free(sum); return status; }
        run(p, m->registers, MM_OUTPUTS);
        for (int c = 0; c < nc; ++c) {
            double q = m->registers[p->coordinates[4 * c]];
            if (i > 0) {
                double step = q - previous[c];
                sum[c] += step - TWO_PI * nearbyint(step / TWO_PI);
            }
            previous[c] = q;
        }
    }
    for (int c = 0; c < nc; ++c)
        m->coordinate_winding[c] = p->coordinates[4 * c + 3] ? nearbyint(sum[c] / TWO_PI) : 0.0;
    m->have_quantity_winding = 1;
    free(previous); free(sum);
    return MM_OK;
}

int mm_engine(mm_model *m, int table, const double *phi1, int n, double *out)
{
    const mm_program *p = m->program;
    int rows = mm_rows(m, table), status = MM_OK;
    double x[2 * 3 * MAX_LINKS * 64];
    if (table == MM_TABLE_QUANTITIES) status = coordinate_winding(m);
    if (table == MM_TABLE_REACTIONS) {
        if (rows > (int)(sizeof x / sizeof x[0])) return MM_NO_MEMORY;
        status = reaction_mask(m);
    }
    if (status) return status;
    for (int i = 0; i < n; ++i) {
        if (table == MM_TABLE_REACTIONS) {
            if ((status = reactions_at(m, phi1[i], x))) return status;
            for (int k = 0; k < rows; ++k) x[k] = m->reaction_kept[k] ? x[k] : 0.0;
        } else {
            if ((status = mm_evaluate(m, phi1[i]))) return status;
            if (table == MM_TABLE_QUANTITIES) {
                run(p, m->registers, MM_OUTPUTS);
                for (int c = 0; c < p->n_coordinates; ++c) {
                    const int *f = p->coordinates + 4 * c;
                    x[3 * c] = m->registers[f[0]] - m->coordinate_winding[c] * phi1[i];
                    x[3 * c + 1] = m->registers[f[1]];
                    x[3 * c + 2] = m->registers[f[2]];
                }
            } else {
                for (int k = 0; k < rows; ++k) x[k] = m->registers[p->rows[k]];
            }
        }
        for (int k = 0; k < rows; ++k) {
            double v = x[k];
            /* a value a table cannot hold (1e300 too: its cubics would overflow) */
            if (!(fabs(v) < 1e150)) {
                m->error_angle = phi1[i];
                m->error_index = k;
                m->error_value = v;
                return MM_NOT_FINITE;
            }
            out[k * n + i] = v;
        }
    }
    return MM_OK;
}

/* ------------------------------------------------------------------------------ the tabulator */
/* the twiddles of one transform size, computed once per size (a recurrence would drift by 1e-13
 * over a 4096-point transform), laid out stage by stage: entry half + k of stage len = 2 half is
 * e^{-2 pi i k / len}, so a stage reads its twiddles contiguously; and the bit-reversal order */
typedef struct {
    int size;
    double *c, *s;
    int *reversed;
} twiddles;

static int twiddles_for(twiddles *w, int size)
{
    if (w->size == size) return 1;
    free(w->c);
    free(w->s);
    free(w->reversed);
    w->c = malloc(sizeof(double) * (size + 1));
    w->s = malloc(sizeof(double) * (size + 1));
    w->reversed = malloc(sizeof(int) * (size + 1));
    w->size = 0;
    if (!w->c || !w->s || !w->reversed) return 0;
    /* the last stage's e^{-2 pi i k / size}, k < size/2, from cos and sin on the first eighth of
     * the turn and the symmetries of the others (exact: a swap and a sign) */
    int top = size / 2, eighth = size / 8, quarter = size / 4;
    double *c = w->c + top, *s = w->s + top;
    for (int k = 0; k < top; ++k) {
        double co, si;
        if (size < 8 || k <= eighth) {
            co = cos(TWO_PI * k / size);
            si = sin(TWO_PI * k / size);
        } else if (k <= quarter) {
            co = sin(TWO_PI * (quarter - k) / size);
            si = cos(TWO_PI * (quarter - k) / size);
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
static void fft(double *re, double *im, int n, int inverse, const twiddles *w)
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
static void rfft(const double *x, int n, double *sr, double *si, double *wr, double *wi, twiddles *tw)
{
    for (int i = 0; i < n; ++i) { wr[i] = x[i]; wi[i] = 0.0; }
    twiddles_for(tw, n);
    fft(wr, wi, n, 0, tw);
    for (int k = 0; k <= n / 2; ++k) { sr[k] = wr[k]; si[k] = wi[k]; }
}

/* the interpolant of n samples (series ar, ai: n/2 + 1) or its derivative at k 2 pi / m + shift
 * (numerics.series_on_grid): the zero-padded Hermitian spectrum X (m/2 + 1 terms) inverted by one
 * complex transform of m/2 points, z_j = x_2j + i x_2j+1 = IDFT(E + i O) with
 * E_k = X_k + conj(X_{m/2-k}), O_k = (X_k - conj(X_{m/2-k})) e^{2 pi i k / m}.
 * pc, ps: cos and sin of k shift, k <= n/2 (series_t's phases, one set for every row);
 * xr, xi: the padded spectrum, zero beyond n/2 on entry and on return */
static void on_grid(const double *ar, const double *ai, int n, int m, const double *pc, const double *ps,
                    int derivative, double *xr, double *xi, double *re, double *im, twiddles *half,
                    twiddles *full, double *out)
{
    int h = m / 2, top = n / 2 < h ? n / 2 : h;
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
    twiddles_for(full, m);
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
    twiddles_for(half, h);
    fft(re, im, h, 1, half);
    double inv = 1.0 / m;
    for (int j = 0; j < h; ++j) {
        out[2 * j] = re[j] * inv;
        out[2 * j + 1] = im[j] * inv;
    }
}

typedef struct {
    int rows, n;
    double *sr, *si;          /* rows x (n/2 + 1) */
    double *xr, *xi;          /* a padded spectrum, kept zero between uses */
    double *pc, *ps;          /* cos and sin of k shift, k <= n/2 */
    twiddles *half, *full;
} series_t;

static void series_phases(int n, double shift, double *pc, double *ps)
{
    for (int k = 0; k <= n / 2; ++k) {
        pc[k] = cos(k * shift);
        ps[k] = sin(k * shift);
    }
}

/* one row of the series at m angles (+ the shift whose phases pc, ps are), value or derivative */
static void series_row(const series_t *s, int r, int m, const double *pc, const double *ps, int derivative,
                       double *re, double *im, double *out)
{
    int w = s->n / 2 + 1;
    on_grid(s->sr + r * w, s->si + r * w, s->n, m, pc, ps, derivative, s->xr, s->xi, re, im, s->half, s->full, out);
}

/* the series of every row at m angles (+ shift), value or derivative: out rows x m. Each row by
 * its own transform: two rows packed into one complex transform would leak each other's
 * rounding, and a row is checked relative to its own scale (an exact zero must stay zero) */
static void series_values(series_t *s, int m, double shift, int derivative, double *re, double *im, double *out)
{
    series_phases(s->n, shift, s->pc, s->ps);
    for (int r = 0; r < s->rows; ++r) series_row(s, r, m, s->pc, s->ps, derivative, re, im, out + (size_t)r * m);
}

/* the spline of samples (dynamics.tabulated._from_samples), where the Fourier series does not
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
    twiddles tw = {0, NULL, NULL, NULL};
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
        if (!values || !exact || !angles || !cubics || !re || !im || !eigen || !errors || !twiddles_for(&tw, n)) {
            status = MM_NO_MEMORY;
            break;
        }
        for (int i = 0; i < n; ++i) angles[i] = i * h;
        if ((status = mm_engine(m, table, angles, n, values))) break;
        for (int i = 0; i < n; ++i) { angles[i] = (i + 0.5) * h; angles[n + i] = (i + 0.3) * h; }
        if ((status = mm_engine(m, table, angles, 2 * n, exact))) break;
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
            fft(re, im, n, 0, &tw);
            for (int k = 0; k < n; ++k) { re[k] /= eigen[k]; im[k] /= eigen[k]; }
            fft(re, im, n, 1, &tw);                     /* M = re / n */
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
            double step = y[(k + 1) % n] - y[k], largest = exact[k];
            qsort(exact, (size_t)n, sizeof(double), compare);
            double median = 0.5 * (exact[n / 2 - 1] + exact[n / 2]) + 1e-300;
            m->error_index = worst;
            m->error_value = error;
            m->error_angle = k * h;
            m->error_step = step;
            m->error_jumps = largest > 1e3 * median;
            status = MM_NOT_TABULATED;
            break;
        }
    }
    free(values); free(exact); free(angles); free(cubics); free(re); free(im); free(eigen); free(errors);
    free(tw.c); free(tw.s); free(tw.reversed);
    return status;
}

int mm_tabulate(mm_model *m, int table, double tolerance, double **cubics_out, int *m_out, double *error_out,
                int *n_series)
{
    const int rows = mm_rows(m, table), n_first = 64, n_last = 4096, m_last = 1 << 16;
    const double budget = 0.5 * tolerance;
    int n = n_first, status = MM_OK;
    double last = INFINITY, error = 0.0;
    /* working memory for the largest case */
    size_t big = (size_t)(n_last > 8192 ? n_last : 8192);     /* grown with the intervals */
    double *samples = malloc(sizeof(double) * rows * n_last);
    double *exact = malloc(sizeof(double) * rows * (n_last + n_last / 4));
    double *angles = malloc(sizeof(double) * (n_last + n_last / 4) * 2);
    double *scale = malloc(sizeof(double) * rows);
    double *re = malloc(sizeof(double) * big), *im = malloc(sizeof(double) * big);
    double *work = malloc(sizeof(double) * rows * (n_last + n_last / 4));
    double *phases = malloc(sizeof(double) * 4 * (n_last / 2 + 1));
    twiddles half = {0, NULL, NULL, NULL}, full = {0, NULL, NULL, NULL}, forward = {0, NULL, NULL, NULL};
    series_t s = {rows, 0, malloc(sizeof(double) * rows * (n_last / 2 + 1)), malloc(sizeof(double) * rows * (n_last / 2 + 1)),
                  calloc(big / 2 + 1, sizeof(double)), calloc(big / 2 + 1, sizeof(double)),
                  malloc(sizeof(double) * (n_last / 2 + 1)), malloc(sizeof(double) * (n_last / 2 + 1)), &half, &full};
    double *values = NULL, *slopes = NULL, *cubics = NULL;
    if (!samples || !exact || !angles || !scale || !re || !im || !work || !phases || !s.sr || !s.si || !s.xr || !s.xi || !s.pc ||
        !s.ps) { status = MM_NO_MEMORY; goto done; }

    /* the first samples and their checks in one engine call */
    {
        double h = TWO_PI / n;
        int c = 0;
        for (int i = 0; i < n; ++i) angles[c++] = i * h;
        for (int i = 0; i < n; ++i) angles[c++] = (i + 0.5) * h;
        for (int i = 0; i < n; i += 4) angles[c++] = (i + 0.3) * h;
        double *first = malloc(sizeof(double) * rows * c);
        if (!first) { status = MM_NO_MEMORY; goto done; }
        status = mm_engine(m, table, angles, c, first);
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
            rfft(samples + r * n, n, s.sr + r * (n / 2 + 1), s.si + r * (n / 2 + 1), re, im, &forward);
        /* the interpolant at the midpoints, and at 0.3 of every fourth interval */
        series_values(&s, n, 0.5 * h, 0, re, im, work);
        error = 0.0;
        for (int r = 0; r < rows; ++r)
            for (int i = 0; i < n; ++i) {
                double e = fabs(work[r * n + i] - exact[r * checks + i]) / scale[r];
                if (!(e <= error)) error = e;
            }
        series_values(&s, n, 0.3 * h, 0, re, im, work);
        for (int r = 0; r < rows; ++r)
            for (int i = 0; i < n; i += 4) {
                double e = fabs(work[r * n + i] - exact[r * checks + n + i / 4]) / scale[r];
                if (!(e <= error)) error = e;
            }
        if (error <= budget) break;
        if (2 * n > n_last || (n >= 4 * n_first && error > 0.25 * last)) { status = MM_NOT_TABULATED; goto spline; }
        last = error;
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
        if ((status = mm_engine(m, table, angles, c, exact))) goto done;
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
        double predicted = TWO_PI * pow(fourth / (384.0 * budget), 0.25);
        int mm = 1 << (int)nearbyint(log2(fmax(predicted, 1.0)));
        if (mm < n) mm = n;
        if (mm > m_last) mm = m_last;
        for (;;) {
            double hm = TWO_PI / mm;
            free(values); free(slopes); free(cubics);
            values = slopes = cubics = NULL;
            if ((size_t)mm > big) {
                big = (size_t)mm;
                free(re); free(im); free(s.xr); free(s.xi);
                re = malloc(sizeof(double) * big); im = malloc(sizeof(double) * big);
                s.xr = calloc(big / 2 + 1, sizeof(double)); s.xi = calloc(big / 2 + 1, sizeof(double));
                if (!re || !im || !s.xr || !s.xi) { status = MM_NO_MEMORY; goto done; }
            }
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
            series_phases(n, 0.0, pc, ps);
            series_phases(n, 0.5 * hm, mid_c, mid_s);
            for (int r = 0; r < rows; ++r) {
                series_row(&s, r, mm, pc, ps, 0, re, im, values);
                series_row(&s, r, mm, pc, ps, 1, re, im, slopes);
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
                    series_row(&s, r, mm, mid_c, mid_s, 0, re, im, values);
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
    free(samples); free(exact); free(angles); free(scale); free(re); free(im); free(work); free(phases);
    free(s.sr); free(s.si); free(s.xr); free(s.xi); free(s.pc); free(s.ps); free(values); free(slopes); free(cubics);
    free(half.c); free(half.s); free(half.reversed); free(full.c); free(full.s); free(full.reversed);
    free(forward.c); free(forward.s); free(forward.reversed);
    return status;
}

void mm_release(double *cubics)
{
    free(cubics);
}
