/* The mechanism model's checks at parameter values (crank_mechanism.h's mm_check, mm_prepare): the
 * assembly over the turn (the contours close, no dead point, no lock, a closed form that does not
 * jump) and the loads' searches (rocker extremes, reversals, bands) that give the switch schedule.
 * The Python engine states the same rules (mechanisms/contour.py, dynamics/loads.py):
 * tests/test_c_model.py compares them. */
#include "crank_mechanism_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

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
    return mm_factor_unknowns(m, t, J, Ju, piv, cond);
}

/* one angle of the assembly scan: its residual and signed conditioning, and with ``full`` its
 * kinematics in the registers (what the searches start from). A closed form's positions at one of
 * the turn table's own angles are that table's row, bit for bit what mm_positions() gives there
 * (the same closed form at the same angle, moved by the same whole turns): not computed again. */
static int scan_angle(mm_model *m, double phi1, int turn_row, int full, double *cond, double *residual)
{
    const mm_program *p = m->program;
    double q[MAX_Q];
    if (turn_row >= 0 && p->closed_form && m->have_turn && m->turn_start == 0.0)
        memcpy(q, m->turn + (size_t)turn_row * p->n_q, sizeof(double) * p->n_q);
    else {
        int status = mm_positions(m, phi1, q);
        if (status) { m->error_angle = phi1; return status; }
    }
    if (full) return mm_kinematics_of(m, phi1, q, cond, residual);
    term_value t[256];
    mm_terms_at(m, q, t);
    *residual = mm_residual_max(m, t);
    int status = conditioning_of(m, t, cond);
    if (status) m->error_angle = phi1;
    return status;
}

/* q' at positions q (raw or unwrapped: whole turns do not change it) into dq */
static int rates_at(const mm_model *m, const double *q, double *dq)
{
    double ddq[MAX_Q];
    term_value t[256];
    mm_terms_at(m, q, t);
    return mm_transfer(m, t, dq, ddq, NULL);
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
    const int nq = p->n_q, rows = MM_TURN_POINTS + 1, width = mm_kinematics_width(p);
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
        int i = 0;
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
                if ((status = mm_closed_positions(m, fine[k], row)) == MM_OK) status = rates_at(m, row, fine_dq + k * nq);
                if (status) { m->error_angle = fine[k]; break; }
                for (int c = 1; c < nq && k > 0; ++c)          /* unwrapped along the fine angles */
                    if (p->angle_column[c]) row[c] = mm_nearest_turn(row[c - nq], row[c]);
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
    int width = mm_kinematics_width(p);
    /* the turn table's angles are every MM_TURN_POINTS-th of the turn: every other scan angle */
    const int per_row = points / MM_TURN_POINTS;
    int singular = -1;
    for (int i = 0; i < points && status == MM_OK; ++i) {
        /* with the residual of the positions found (a closed form must satisfy the contours) */
        double res;
        int kept = !coarse && i % 2 == 0;          /* every other scan angle: where the searches start */
        status = scan_angle(m, i * h, i % per_row == 0 ? i / per_row : -1, kept, signed_ + i, &res);
        if (status == MM_SINGULAR) {
            /* the residuals of the whole turn first, as the engine's check: a closed form that
             * misses the contours where its Jacobian is singular is refused for that */
            if (singular < 0) singular = i;
            signed_[i] = 0.0;
            status = MM_OK;
        }
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
    if (singular >= 0) {
        m->error_angle = singular * h;
        free(signed_);
        return MM_SINGULAR;
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
    int status = mm_kinematics(m, phi1, NULL);
    if (status) return status;
    mm_run(m->program, m->registers, section);
    *value = m->registers[m->program->sections[2 * section + 1] > 0
                          ? m->program->code[5 * (m->program->sections[2 * section + 1] - 1) + 1] : 0];
    return MM_OK;
}

enum { SCAN_ANGLES = MM_SCAN_POINTS / 2 };

/* the section's value at the scan's SCAN_ANGLES angles (2 pi / 720 apart, from 0) into v; returns
 * its largest magnitude */
static double scan_section(mm_model *m, int section, double *v)
{
    const mm_program *p = m->program;
    int width = mm_kinematics_width(p);
    int last = p->code[5 * (p->sections[2 * section + 1] - 1) + 1];
    double scale = 0.0;
    for (int i = 0; i < SCAN_ANGLES; ++i) {
        /* the scan's kinematics at these angles, kept by the assembly check */
        memcpy(m->registers + p->phi1, m->scan + i * width, sizeof(double) * width);
        mm_run(p, m->registers, section);
        v[i] = m->registers[last];
        scale = fmax(scale, fabs(v[i]));
    }
    return scale;
}

/* where the section's value crosses level over the turn: (angle, rising) appended to roots
 * (sign changes on 720 angles, then the secant kept in its bracket, as numerics.bracketed_roots) */
static int crossings(mm_model *m, int section, double level, double *roots, int *rising, int *n_roots, int max_roots)
{
    enum { N = SCAN_ANGLES };
    double v[N + 1], h = TWO_PI / N;
    int status;
    double scale = scan_section(m, section, v);
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

/* the active frictions' place among the active ones, by declared index (-1: not active) */
static int active_place(const mm_model *m, int declared)
{
    for (int k = 0; k < m->n_active; ++k)
        if (m->active[k] == declared) return k;
    return -1;
}

/* whether each active friction's joint moves (dynamics.friction.JointFrictions.moving): its rate's
 * peak on the scan's angles against the largest one's, at least 1 */
static void friction_motion(mm_model *m)
{
    const mm_program *p = m->program;
    double v[SCAN_ANGLES], largest = 1.0;
    for (int s = 0; s < p->n_searches; ++s) {
        const int *f = p->searches + MM_SEARCH_FIELDS * s;
        int k = f[0] == MM_FRICTION_RATE ? active_place(m, f[3]) : -1;
        if (k < 0) continue;
        m->rate_peak[k] = scan_section(m, f[1], v);
        largest = fmax(largest, m->rate_peak[k]);
    }
    for (int k = 0; k < m->n_active; ++k) m->moving[k] = m->rate_peak[k] > 1e-12 * largest;
}

/* each active friction's relative rate at phi1 (0 where its joint does not move) into rates */
static int friction_rates(mm_model *m, double phi1, double *rates)
{
    const mm_program *p = m->program;
    int status = mm_kinematics(m, phi1, NULL);
    if (status) return status;
    mm_run(p, m->registers, MM_REACTIONS);
    for (int k = 0; k < m->n_active; ++k)
        rates[k] = m->moving[k] ? m->registers[p->frictions[3 * m->active[k] + 2]] : 0.0;
    return MM_OK;
}

/* each active friction's sign on each switch interval forward (JointFrictions.signs at the
 * intervals' middles): its rate's, and on a zero of the rate (to 1e-9 of its peak) the sign of
 * the motion that follows, a microradian further */
static int friction_signs(mm_model *m, int intervals, const double *mids)
{
    double rates[MM_MAX_FRICTIONS], ahead[MM_MAX_FRICTIONS];
    for (int i = 0; i < intervals; ++i) {
        int status = friction_rates(m, mids[i], rates);
        if (status) return status;
        int near = 0;
        for (int k = 0; k < m->n_active; ++k) near |= m->moving[k] && fabs(rates[k]) <= 1e-9 * m->rate_peak[k];
        if (near && (status = friction_rates(m, mids[i] + 1e-6, ahead))) return status;
        for (int k = 0; k < m->n_active; ++k) {
            double rate = m->moving[k] && fabs(rates[k]) <= 1e-9 * m->rate_peak[k] ? ahead[k] : rates[k];
            m->friction_signs[i * m->n_active + k] = (rate > 0.0) - (rate < 0.0);
        }
    }
    return MM_OK;
}

static int searches(mm_model *m)
{
    const mm_program *p = m->program;
    double *r = m->registers;
    m->n_switches = 0;
    friction_motion(m);
    for (int s = 0; s < p->n_searches; ++s) {
        const int *f = p->searches + MM_SEARCH_FIELDS * s;
        double roots[MM_MAX_SWITCHES];
        int rising[MM_MAX_SWITCHES], n = 0, status;
        m->error_index = s;
        if (f[0] == MM_FRICTION_RATE) {
            int k = active_place(m, f[3]);
            if (k < 0 || !m->moving[k]) continue;
        }
        if (f[0] == MM_BAND) {
            double low = r[f[3]], high = r[f[4]], stroke = high - low;
            double levels[4] = {low + r[f[5]] * stroke, low + r[f[6]] * stroke,
                                high - r[f[5]] * stroke, high - r[f[6]] * stroke};
            qsort(levels, 4, sizeof(double), mm_ascending);
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
        if (n == 0 && f[0] == MM_REVERSALS) return MM_NO_REVERSAL;
        for (int k = 0; k < n; ++k)
            if ((status = add_switch(m, roots[k]))) return status;
        if (f[0] != MM_FRICTION_RATE && f[3] >= 0) {
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
    qsort(m->switches, m->n_switches, sizeof(double), mm_ascending);
    /* the switched loads' values on each interval, for each direction of the crank */
    int nc = p->n_columns;
    /* no switch: one interval, the whole turn, its values those anywhere on it (a kink whose argument
     * keeps its sign; loads.slider_schedule does the same) */
    int intervals = m->n_switches > 0 ? m->n_switches : 1;
    double mids[MM_MAX_SWITCHES];
    for (int k = 0; k < intervals; ++k) {
        double next = k + 1 < m->n_switches ? m->switches[k + 1] : (m->n_switches ? m->switches[0] + TWO_PI : 0.0);
        mids[k] = m->n_switches ? fmod(0.5 * (m->switches[k] + next), TWO_PI) : 0.5 * TWO_PI;
    }
    if (m->n_active > 0) {
        int status = friction_signs(m, intervals, mids);
        if (status) return status;
    }
    if (nc == 0) return MM_OK;
    for (int k = 0; k < intervals; ++k) {
        double mid = mids[k];
        int status = mm_kinematics(m, mid, NULL);
        if (status) return status;
        for (int d = 0; d < 2; ++d) {
            r[p->omega1] = d == 0 ? 1.0 : -1.0;
            mm_run(p, r, MM_VALUES);
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
