/* The functions of the mechanism model's tables at any crank angles (crank_mechanism.h's mm_rows,
 * mm_engine): the reduced model's rows, the [[outputs]]' and ports' coordinates less their whole
 * turns, and the joint reactions' terms (dynamics/reactions.py's Newton-Euler, term by term). */
#include "crank_mechanism_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int mm_reaction_terms(const mm_model *m)
{
    return m->program->n_terms_reaction - m->program->n_frictions + m->n_active;
}

/* the joint of active friction k's reaction components: its first column, and their count */
static int friction_columns(const mm_model *m, int k, int *first)
{
    const mm_program *p = m->program;
    int joint = p->frictions[3 * m->active[k]];
    *first = 2 * joint;
    return p->joints[5 * joint] ? 1 : 2;      /* a slide's normal force; a pin's two components */
}

int mm_friction_components(const mm_model *m)
{
    int n = 0, first;
    for (int k = 0; k < m->n_active; ++k) n += friction_columns(m, k, &first);
    return n;
}

int mm_rows(const mm_model *m, int table)
{
    const mm_program *p = m->program;
    if (table == MM_TABLE_QUANTITIES) return 3 * p->n_coordinates;
    if (table == MM_TABLE_REACTIONS) return 2 * p->n_joints * mm_reaction_terms(m);
    if (table == MM_TABLE_FRICTION) return m->n_active + mm_friction_components(m) * mm_reaction_terms(m);
    return p->n_rows;
}

/* the reaction table's terms among the program's: its loads' terms, then the active frictions'
 * unit terms (an inactive one's is left out); returns their count */
static int term_map(const mm_model *m, int *map)
{
    const mm_program *p = m->program;
    int base = p->n_terms_reaction - p->n_frictions, n = 0;
    for (int t = 0; t < base; ++t) map[n++] = t;
    for (int k = 0; k < m->n_active; ++k) map[n++] = base + m->active[k];
    return n;
}

/* a point's registers (x, y, dx, dy, ddx, ddy) */
static const double *point_registers(const mm_model *m, int point)
{
    const mm_program *p = m->program;
    return m->registers + p->kinematics + 3 * (p->n_q - 1) + 6 * point;
}

/* every joint reaction's terms at phi1 (dynamics/reactions.py, one term at a time as
 * reaction_table.tabulate_reactions): out[component * terms + term] */
static int reactions_at(mm_model *m, double phi1, double *out)
{
    const mm_program *p = m->program;
    const double *r = m->registers;
    int status = mm_kinematics(m, phi1, NULL);
    if (status) return status;
    mm_run(p, m->registers, MM_REACTIONS);
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
    if (!mm_lu_factor(size, A, piv, &det)) { m->error_angle = phi1; return MM_SINGULAR; }
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
        mm_lu_solve(size, A, piv, b);
        for (int k = 0; k < 2 * p->n_joints; ++k) out[k * nt + t] = b[k];
    }
    return MM_OK;
}

/* which reaction terms a component has: the others are zero up to the solve's round-off, and
 * exactly zero in the table (reaction_table.tabulate_reactions' probe of 96 angles) */
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

/* the friction table's functions at phi1 from the reaction terms x (all the program's, as
 * reactions_at gives them) and the rates in the registers: friction_table.tabulate_frictions' rows,
 * the terms not kept (friction_mask) zero unless keep is NULL; map, n_terms: term_map's */
static void friction_rows(const mm_model *m, const double *x, const int *keep, const int *map, int n_terms,
                          double *out)
{
    const mm_program *p = m->program;
    int nt = p->n_terms_reaction, row = m->n_active, first;
    for (int k = 0; k < m->n_active; ++k)
        out[k] = m->moving[k] ? m->registers[p->frictions[3 * m->active[k] + 2]] : 0.0;
    for (int k = 0; k < m->n_active; ++k) {
        int count = friction_columns(m, k, &first);
        for (int c = first; c < first + count; ++c)
            for (int t = 0; t < n_terms; ++t, ++row) {
                double v = x[c * nt + map[t]];
                out[row] = (keep == NULL || keep[row - m->n_active]) ? v : 0.0;
            }
    }
}

/* which terms each friction component has (reaction_table.zero_terms on its components: a probe of 96
 * angles per turn over the machine's cycle, each term against its largest over the components) */
static int friction_mask(mm_model *m)
{
    const mm_program *p = m->program;
    if (m->have_friction_mask) return MM_OK;
    int map[3 * MAX_LINKS * 64], n_terms = term_map(m, map), rows = mm_rows(m, MM_TABLE_FRICTION) - m->n_active;
    int n_probe = 97 * (p->cycle_turns > 1 ? p->cycle_turns : 1) - 1;
    double period = TWO_PI * (p->cycle_turns > 1 ? p->cycle_turns : 1);
    double *largest = calloc((size_t)rows + 1, sizeof(double)), *term_largest = calloc((size_t)n_terms + 1, sizeof(double));
    double *x = malloc(sizeof(double) * 2 * p->n_joints * p->n_terms_reaction + 1);
    double *y = malloc(sizeof(double) * (m->n_active + rows) + 1);
    free(m->friction_kept);
    m->friction_kept = malloc(sizeof(int) * rows + 1);
    int status = (largest && term_largest && x && y && m->friction_kept) ? MM_OK : MM_NO_MEMORY;
    for (int i = 0; i < n_probe && status == MM_OK; ++i) {
        /* numpy.linspace(0, period, n_probe + 1)'s points but the last */
        status = reactions_at(m, i * (period / n_probe), x);
        if (status) break;
        friction_rows(m, x, NULL, map, n_terms, y);
        for (int k = 0; k < rows; ++k) {
            largest[k] = fmax(largest[k], fabs(y[m->n_active + k]));
            term_largest[k % n_terms] = fmax(term_largest[k % n_terms], fabs(y[m->n_active + k]));
        }
    }
    for (int k = 0; k < rows && status == MM_OK; ++k)
        m->friction_kept[k] = largest[k] > 1e-12 * term_largest[k % n_terms];
    if (status == MM_OK) m->have_friction_mask = 1;
    free(largest); free(term_largest); free(x); free(y);
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
        int status = mm_kinematics(m, i * (TWO_PI / 512), NULL);
        if (status) { free(previous); free(sum); return status; }
        mm_run(p, m->registers, MM_OUTPUTS);
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

static int engine_rows(mm_model *m, int table, const double *phi1, int n, double *out, int rows, int n_terms,
                       const int *map, double *x, double *all);

int mm_engine(mm_model *m, int table, const double *phi1, int n, double *out)
{
    const mm_program *p = m->program;
    int rows = mm_rows(m, table), status = MM_OK, nt = p->n_terms_reaction, map[3 * MAX_LINKS * 64];
    int n_terms = term_map(m, map);
    double x[2 * 3 * MAX_LINKS * 64], *all = NULL;     /* all: every program term of every reaction */
    if (rows > (int)(sizeof x / sizeof x[0])) return MM_NO_MEMORY;
    if (table == MM_TABLE_QUANTITIES) status = coordinate_winding(m);
    if (table == MM_TABLE_REACTIONS) status = reaction_mask(m);
    if (table == MM_TABLE_FRICTION) status = friction_mask(m);
    if (status) return status;
    if (table == MM_TABLE_REACTIONS || table == MM_TABLE_FRICTION) {
        all = malloc(sizeof(double) * 2 * p->n_joints * nt + 1);
        if (!all) return MM_NO_MEMORY;
    }
    status = engine_rows(m, table, phi1, n, out, rows, n_terms, map, x, all);
    free(all);
    return status;
}

static int engine_rows(mm_model *m, int table, const double *phi1, int n, double *out, int rows, int n_terms,
                       const int *map, double *x, double *all)
{
    const mm_program *p = m->program;
    int status, nt = p->n_terms_reaction;
    for (int i = 0; i < n; ++i) {
        if (table == MM_TABLE_REACTIONS) {
            if ((status = reactions_at(m, phi1[i], all))) return status;
            for (int c = 0; c < 2 * p->n_joints; ++c)
                for (int t = 0; t < n_terms; ++t) {
                    int k = c * nt + map[t];
                    x[c * n_terms + t] = m->reaction_kept[k] ? all[k] : 0.0;
                }
        } else if (table == MM_TABLE_FRICTION) {
            if ((status = reactions_at(m, phi1[i], all))) return status;
            friction_rows(m, all, m->friction_kept, map, n_terms, x);
        } else {
            if ((status = mm_evaluate(m, phi1[i]))) return status;
            if (table == MM_TABLE_QUANTITIES) {
                mm_run(p, m->registers, MM_OUTPUTS);
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
