/* The mechanism model in C (crank_mechanism.h), its core: the program's evaluator, the linear
 * algebra, the contour kinematics (closed form or Newton with continuation along the turn, the
 * turn table, whole turns counted) and the binding of a program to parameter values. The
 * assembly check and searches (crank_assembly.c), the tables' functions (crank_engine.c) and the
 * tabulator (crank_tabulator.c) build on it. Re-entrant: everything lives in mm_model. */
#include "crank_mechanism_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------ the evaluator */
void mm_run(const mm_program *p, double *r, int section)
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
        case MM_TANH: v = tanh(a); break;
        case MM_SINH: v = sinh(a); break;
        case MM_COSH: v = cosh(a); break;
        default: v = NAN;
        }
        r[code[1]] = v;
    }
}

double mm_law(const void *context, int column, double omega)
{
    mm_model *m = (mm_model *)context;       /* the laws' registers are scratch: nothing else reads them */
    const mm_program *p = m->program;
    if (!p->laws || column < 0 || column >= p->n_columns || p->laws[column] < 0 || p->law_speed < 0) return NAN;
    double *speed = &m->registers[p->law_speed];
    /* every column's law at once: a step asks for each at the same speed (a NaN speed runs again) */
    if (!(m->law_ready && *speed == omega && signbit(*speed) == signbit(omega))) {
        *speed = omega;
        mm_run(p, m->registers, MM_LAWS);
        m->law_ready = 1;
    }
    return m->registers[p->laws[column]];
}

/* --------------------------------------------------------------------------- linear algebra */
/* LU factors of A (n x n row-major, partial pivoting) in place, its signed determinant into *det;
 * 0 when A is singular */
int mm_lu_factor(int n, double *A, int *piv, double *det)
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

void mm_lu_solve(int n, const double *LU, const int *piv, double *b)
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
    if (!mm_lu_factor(n, A, piv, &det)) return 0;
    mm_lu_solve(n, A, piv, b);
    return 1;
}

/* ------------------------------------------------------------------------------ the contours */
void mm_terms_at(const mm_model *m, const double *q, term_value *t)
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

double mm_residual_max(const mm_model *m, const term_value *t)
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
        mm_terms_at(m, q, t);
        if (mm_residual_max(m, t) <= tol) return MM_OK;
        residual(m, t, F);
        jacobian(m, t, J);
        unknown_block(nq, J, Ju);
        if (!solve(n, Ju, F)) return MM_NO_CONVERGENCE;
        for (int j = 0; j < n; ++j) q[j + 1] -= F[j];
    }
    mm_terms_at(m, q, t);
    return mm_residual_max(m, t) <= 1e3 * tol ? MM_OK : MM_NO_CONVERGENCE;
}

/* the contours' Jacobian J (2k x n_q) at the terms t and the LU factors of its unknowns' block Ju
 * (pivots piv); the signed conditioning into *cond (may be NULL): the det of the column-normalised
 * block, 1 for orthogonal columns, 0 at a dead point, det(Ju D) = det(Ju) prod D from the same
 * factors as the solves. MM_SINGULAR where Ju is singular; n_q = 1 (no unknown) is regular. */
int mm_factor_unknowns(const mm_model *m, const term_value *t, double *J, double *Ju, int *piv, double *cond)
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
    int regular = mm_lu_factor(n, Ju, piv, &det);
    if (cond) *cond = det / norms;
    return regular ? MM_OK : MM_SINGULAR;
}

/* q', q'' at solved positions (their terms t); the signed conditioning into *cond (may be NULL) */
int mm_transfer(const mm_model *m, const term_value *t, double *dq, double *ddq, double *cond)
{
    const mm_program *p = m->program;
    int nq = p->n_q, n = nq - 1, k = p->n_contours;
    double J[MAX_Q * MAX_Q], Ju[MAX_Q * MAX_Q], rhs[2 * MAX_Q];
    int piv[MAX_Q];
    int status = mm_factor_unknowns(m, t, J, Ju, piv, cond);
    dq[0] = 1.0;
    ddq[0] = 0.0;
    if (n == 0 || status) return status;
    for (int i = 0; i < n; ++i) rhs[i] = -J[i * nq];
    mm_lu_solve(n, Ju, piv, rhs);
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
    mm_lu_solve(n, Ju, piv, quad);
    for (int j = 0; j < n; ++j) ddq[j + 1] = quad[j];
    return MM_OK;
}

/* the closed form's positions at phi1 (its angles as the expressions give them) */
int mm_closed_positions(mm_model *m, double phi1, double *q)
{
    const mm_program *p = m->program;
    double *r = m->registers;
    r[p->phi1] = phi1;
    mm_run(p, r, MM_CLOSED);
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
        q[j] = mm_nearest_turn(near, q[j]);
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
    mm_terms_at(m, base, t);
    int status = mm_transfer(m, t, dq, ddq, NULL);
    if (status) return status;
    for (int j = 0; j < nq; ++j) q[j] = base[j] + dphi * dq[j] + 0.5 * dphi * dphi * ddq[j];
    q[0] = phi1;
    return newton(m, q);
}

int mm_positions(mm_model *m, double phi1, double *q)
{
    int status = m->program->closed_form ? mm_closed_positions(m, phi1, q) : newton_positions(m, phi1, q);
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
            int status = mm_closed_positions(m, i * h, m->turn + i * nq);
            if (status) { m->error_angle = i * h; return status; }
            if (i == 0) continue;
            for (int j = 1; j < nq; ++j) {
                if (!p->angle_column[j]) continue;
                double *now = m->turn + i * nq + j, before = now[-nq];
                *now = mm_nearest_turn(before, *now);
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
            mm_terms_at(m, prev, t);
            status = mm_transfer(m, t, dq, ddq, NULL);
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

static int kinematics_at(mm_model *m, double phi1, double *cond, double *residual_out)
{
    double q[MAX_Q];
    int status = mm_positions(m, phi1, q);
    if (status) { m->error_angle = phi1; return status; }
    return mm_kinematics_of(m, phi1, q, cond, residual_out);
}

/* kinematics_at from the positions q at phi1 */
int mm_kinematics_of(mm_model *m, double phi1, const double *q, double *cond, double *residual_out)
{
    const mm_program *p = m->program;
    double *r = m->registers;
    int nq = p->n_q;
    double dq[MAX_Q], ddq[MAX_Q];
    term_value t[256];
    int status;
    mm_terms_at(m, q, t);
    if (residual_out) *residual_out = mm_residual_max(m, t);
    status = mm_transfer(m, t, dq, ddq, cond);
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

int mm_kinematics(mm_model *m, double phi1, double *cond)
{
    return kinematics_at(m, phi1, cond, NULL);
}

int mm_evaluate(mm_model *m, double phi1)
{
    int status = mm_kinematics(m, phi1, NULL);
    if (status == MM_OK) mm_run(m->program, m->registers, MM_ROWS);
    return status;
}

/* ------------------------------------------------------------------------------ binding */
/* the per-angle registers phi1 .. the last point's: what a scan angle's kinematics leave */
int mm_kinematics_width(const mm_program *p)
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
    free(m->friction_kept);
    m->registers = m->turn = m->winding = m->forces = m->scan = m->coordinate_winding = NULL;
    m->reaction_kept = m->friction_kept = NULL;
}

int mm_bind(mm_model *m, const mm_program *p, const double *parameters, int n_parameters)
{
    memset(m, 0, sizeof *m);
    m->program = p;
    if (p->n_q > MAX_Q || p->n_terms > 256 || p->n_angles > 256 || p->n_links > MAX_LINKS ||
        2 * p->n_joints * p->n_terms_reaction > 2 * 3 * MAX_LINKS * 64 || p->n_q != 1 + 2 * p->n_contours ||
        p->n_frictions > MM_MAX_FRICTIONS || p->n_frictions > p->n_terms_reaction) return MM_NO_MEMORY;
    m->registers = calloc((size_t)p->n_registers, sizeof(double));
    m->turn = malloc(sizeof(double) * (MM_TURN_POINTS + 1) * p->n_q);
    m->winding = calloc((size_t)p->n_q, sizeof(double));
    m->forces = calloc((size_t)2 * (p->n_columns > 0 ? p->n_columns : 1) * MM_MAX_SWITCHES, sizeof(double));
    m->scan = malloc(sizeof(double) * (MM_SCAN_POINTS / 2) * mm_kinematics_width(p));
    if (!m->registers || !m->turn || !m->winding || !m->forces || !m->scan) return MM_NO_MEMORY;
    memcpy(m->registers, parameters, sizeof(double) * n_parameters);
    mm_run(p, m->registers, MM_SETUP);
    for (int i = 0; i < p->n_checks; ++i) {
        double v = m->registers[p->checks[i]];
        if (!(isfinite(v) && v >= 0.0)) {
            m->error_index = i;
            m->error_value = v;
            return MM_CHECK;
        }
    }
    /* a friction whose mu is 0 is none (dynamics.friction.joint_frictions): a design without
     * any runs as before friction existed */
    for (int i = 0; i < p->n_frictions; ++i)
        if (m->registers[p->frictions[3 * i + 1]] > 0.0) m->active[m->n_active++] = i;
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
