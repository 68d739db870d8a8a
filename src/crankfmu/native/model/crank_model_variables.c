/* The native mechanism FMU's variables as a host reads and sets them (crank_model.h's cm_get,
 * cm_set, cm_set_input_derivatives), and its FMU state as bytes: the model's values, its outputs
 * from the output row and the [[outputs]] and joint reactions' tables, each set checked against
 * the variable's range and when it may change. */
#include "crank_model_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "crank_numbers.h"

/* what one read evaluates once for all the variables it reads */
typedef struct {
    double *quantities, *quantity_scratch;
    int have_quantities;
    double *reactions, *reaction_scratch;
    int have_reactions;
    double *frictions;                 /* the friction outputs (FRICTION_M, ...), then scratch */
    int have_frictions;
} Reads;

/* a read's arrays, in the model's scratch after a design's values and trial values (cm_init) */
static Reads reads_of(const Model* m)
{
    const ModelData* d = m->d;
    Reads reads;
    reads.quantities = m->scratch + 2 * ((size_t)d->n_program_parameters + 1);
    reads.quantity_scratch = reads.quantities + d->n_quantities + 1;
    reads.reactions = reads.quantity_scratch + 3 * d->n_quantity_coordinates + 1;
    reads.reaction_scratch = reads.reactions + d->n_reactions + 1;
    reads.frictions = reads.reaction_scratch + (size_t)d->n_reactions * d->reaction_terms + d->reaction_terms + 1;
    reads.have_quantities = reads.have_reactions = reads.have_frictions = 0;
    return reads;
}

/* the joints' friction's outputs at the current point into out (d->n_friction_outputs): M_friction
 * and W_friction from the output row, each active joint's friction by the kernel's solve
 * (ck_friction_values) and its power f k omega1 with its rate from the friction table; 0 for a
 * declared joint whose mu is 0 here (as the Python FMU's friction_now) */
static void friction_outputs(const Model* m, double* out)
{
    const double* row = m->now.row;
    const mm_model* mm = &m->mechanism;
    int n_out = m->d->n_friction_outputs;
    for (int k = 0; k < n_out; k++) out[k] = 0.0;
    out[FRICTION_M] = row[CK_OUT_M_FRICTION];
    out[FRICTION_W] = row[CK_OUT_W_FRICTION];
    if (m->tables.friction == NULL) return;
    double* f = out + n_out;                     /* the scratch after them: n_f + 1, then the rates */
    double* rates = f + MM_MAX_FRICTIONS + 1;
    double y[CK_N_Y] = {row[ROW_PHI1], row[ROW_OMEGA1]};
    if (ck_friction_values(m->now.S, m->now.time, y, row[ROW_EPSILON1], &m->tables, m->now.P, f) < 0) {
        for (int k = FRICTION_JOINTS; k < n_out; k++) out[k] = NAN;
        return;
    }
    ck_periodic_cubics(m->cubics[CM_FRICTION], mm->n_active, m->intervals[CM_FRICTION], m->tables.period,
                       row[ROW_PHI1], rates);
    for (int k = 0; k < mm->n_active; k++) {
        int joint = FRICTION_JOINTS + 2 * mm->active[k];
        out[joint] = f[k];
        out[joint + 1] = f[k] * rates[k] * row[ROW_OMEGA1];
    }
}

/* the outputs of the output row: the contract's, the scenario's [[outputs]] and the joint
 * reactions (all of each kind at once, from their tables, by the kernel's ck_quantity_values and
 * ck_reaction_values: the rules the Python FMU runs too) and the states' derivatives */
static double output_value(const Model* m, int vr, Reads* reads)
{
    const double* row = m->now.row;
    const Variable* v = &m->d->variables[vr];
    if (v->kind == KIND_REACTION) {
        if (!reads->have_reactions) {
            ck_reaction_values(m->cubics[CM_REACTIONS], m->d->n_reactions, mm_reaction_terms(&m->mechanism),
                               m->intervals[CM_REACTIONS], m->now.S,
                               m->now.time, row[ROW_PHI1], row[ROW_OMEGA1], row[ROW_EPSILON1], &m->tables, m->now.P,
                               reads->reaction_scratch, reads->reactions);
            reads->have_reactions = 1;
        }
        return reads->reactions[vr - m->d->vr_first_reaction];
    }
    if (v->kind == KIND_FRICTION) {
        if (!reads->have_frictions) {
            friction_outputs(m, reads->frictions);
            reads->have_frictions = 1;
        }
        return reads->frictions[vr - m->d->vr_first_friction];
    }
    if (v->kind == KIND_DERIVATIVE) {
        double omega = row[ROW_OMEGA1];
        switch (vr - m->d->vr_first_derivative) {
        case 0: return omega;
        case 1: return row[ROW_EPSILON1];
        case 2: return row[ROW_M_MOTOR] * omega;
        case 3: return row[ROW_M_LOAD] * omega;
        case 4: return row[ROW_TAU_E] * omega;
        default: return row[CK_OUT_M_FRICTION] * omega;       /* W_friction's */
        }
    }
    if (v->kind == KIND_QUANTITY) {
        if (!reads->have_quantities) {
            ck_quantity_values(m->cubics[CM_QUANTITIES], m->d->n_quantity_coordinates, m->intervals[CM_QUANTITIES],
                               m->mechanism.coordinate_winding,
                               m->d->n_quantities, m->d->quantity_coordinate, m->d->quantity_order, row[ROW_PHI1], row[ROW_OMEGA1],
                               row[ROW_EPSILON1], reads->quantity_scratch, reads->quantities);
            reads->have_quantities = 1;
        }
        return reads->quantities[vr - m->d->vr_first_quantity];
    }
    if (vr == m->d->vr_e_kin) return ck_kinetic_energy(row[ROW_J_RED], row[ROW_OMEGA1]);
    return row[m->d->output_row[vr]];
}

static int is_computed(int kind)
{
    return kind == KIND_OUTPUT || kind == KIND_QUANTITY || kind == KIND_DERIVATIVE || kind == KIND_REACTION ||
           kind == KIND_FRICTION;
}

void cm_read_values(const Model* m, const unsigned* vr, size_t n, double* out)
{
    Reads reads = reads_of(m);
    for (size_t i = 0; i < n; i++)
        out[i] = is_computed(m->d->variables[vr[i]].kind) ? output_value(m, (int)vr[i], &reads) : m->now.values[vr[i]];
}

/* an input's place among the inputs: the crank's 0, port i 1 + i */
static int input_index(const Model* m, int vr) { return vr == m->d->vr_crank_input ? 0 : 1 + (vr - m->d->vr_first_port); }

/* Co-Simulation between steps: the output row at the inputs as set now, at the communication point
 * (the kernel's rules: ck_point's state and mode there, or in speed causality the row the next step
 * starts from, its slope by ck_speed_slope). Computed at the first read after a set, so a master
 * that sets its inputs and steps pays nothing for it */
static int refresh_row(Model* m, const char* call)
{
    if (cm_ensure_tables(m, call) != CM_OK) return CM_ERROR;
    cm_load_parameters(m);
    double S[CK_STATE_SIZE];
    int status = 0;
    if (m->d->causality_speed) {
        double omega = m->now.values[m->d->vr_crank_input];
        memcpy(S, m->now.S, sizeof S);
        S[CK_Y + 1] = omega;
        S[CK_F + 1] = ck_speed_slope(m->now.S, omega, m->now.input_rate[0], m->now.rate_given[0]);
        ck_speed_row(S, &m->tables, m->now.P, m->now.row);
    } else {
        ck_point(m->now.S, m->now.time, S);
        status = ck_me_derivatives(S, S + CK_Y, &m->tables, m->now.P, NULL, m->now.row);
    }
    m->now.row_stale = 0;
    return status == 0 ? CM_OK : cm_fail(m, "%s: a corrupted state", call);
}

int cm_get(Model* m, const char* call, const unsigned* vr, size_t n, double* value)
{
    if (n > 0 && (!vr || !value)) return cm_fail(m, "%s: null arrays", call);
    if (m->now.row_stale && m->now.phase == CM_STEPPING && refresh_row(m, call) != CM_OK) return CM_ERROR;
    Reads reads = reads_of(m);
    const Model* source = m;
    Model preview;
    int tables_checked = 0;                 /* once per call, at its first computed variable */
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= (unsigned)m->d->n_variables) return cm_fail(m, "%s: no variable has value reference %u", call, vr[i]);
        int k = (int)vr[i];
        if (!is_computed(m->d->variables[k].kind)) {
            value[i] = m->now.values[k];
            continue;
        }
        if (m->now.phase == CM_INSTANTIATED) {
            value[i] = m->d->variables[k].start;
            continue;
        }
        /* the tables of the values the state holds (an FMU state of another design, a design
         * refused since, or in initialisation the start values): built again, or the read refused */
        if (!tables_checked && (m->now.phase >= CM_STEPPING || m->now.phase == CM_INITIALIZATION)) {
            if (cm_ensure_tables(m, call) != CM_OK) return CM_ERROR;
            tables_checked = 1;
        }
        if (m->now.phase == CM_INITIALIZATION && source == m) {
            /* what the start values give, computed on a copy: they may still change */
            preview = *m;
            if (m->model_exchange) {
                cm_me_start(&preview);
                cm_me_evaluate(&preview);
            } else {
                cm_cs_start(&preview);
            }
            source = &preview;
        }
        value[i] = output_value(source, k, &reads);
    }
    return CM_OK;
}

Refusal cm_refusal_text(const Model* m, int vr, double x)
{
    const Variable* v = &m->d->variables[vr];
    if (v->kind != KIND_INPUT) return out_of_range(v->name, x, v->range, v->description);
    Refusal r;
    snprintf(r.text, sizeof r.text, "%s: input %s = %s must be finite (valid range (-inf, inf) %s)", v->name, v->name,
             shortest(x).text, v->unit);
    return r;
}

const char* cm_refusals(const Model* m, char* out, size_t n)
{
    size_t used = 0;
    out[0] = 0;
    for (int vr = 0; vr < m->d->n_variables && used + 1 < n; vr++)
        if (m->now.refused[vr])
            used += (size_t)snprintf(out + used, n - used, "%s%s", used ? "; " : "",
                                     cm_refusal_text(m, vr, m->now.refused_value[vr]).text);
    return out;
}

int cm_set(Model* m, const char* call, const unsigned* vr, size_t n, const double* value)
{
    if (n > 0 && (!vr || !value)) return cm_fail(m, "%s: null arrays", call);
    int changed = 0, input_changed = 0;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= (unsigned)m->d->n_variables) return cm_fail(m, "%s: no variable has value reference %u", call, vr[i]);
        const Variable* v = &m->d->variables[vr[i]];
        double x = value[i];
        if (is_computed(v->kind)) return cm_fail(m, "%s is computed by the FMU: it cannot be set", v->name);
        int fixed_variability = v->kind == KIND_FIXED || cm_sets_initial_state(m, (int)vr[i]);
        if (fixed_variability && m->now.phase >= CM_STEPPING)
            return cm_fail(m, "%s is a fixed parameter: it can be set before the end of initialisation only (reset, "
                           "then set it)", v->name);
        if (!isfinite(x) || (v->has_min && (v->min_inclusive ? x < v->min : x <= v->min)) ||
            (v->has_max && (v->max_inclusive ? x > v->max : x >= v->max))) {
            /* kept: initialisation refuses while it is not set anew (as the Python FMU does) */
            m->now.n_refused += !m->now.refused[vr[i]];
            m->now.refused[vr[i]] = 1;
            m->now.refused_value[vr[i]] = x;
            return cm_fail(m, "%s", cm_refusal_text(m, (int)vr[i], x).text);
        }
        m->now.n_refused -= m->now.refused[vr[i]];
        m->now.refused[vr[i]] = 0;
        if (v->kind == KIND_INPUT) m->now.rate_given[input_index(m, (int)vr[i])] = 0;
        /* the value it has (an input also held, no derivative given): nothing changes, no restart */
        if (x == m->now.values[vr[i]] && (v->kind != KIND_INPUT || m->now.input_rate[input_index(m, (int)vr[i])] == 0.0))
            continue;
        m->now.values[vr[i]] = x;
        if (v->kind == KIND_FIXED || v->kind == KIND_TUNABLE) m->tables_stale = 1;
        if (v->kind == KIND_INPUT) m->now.input_rate[input_index(m, (int)vr[i])] = 0.0;   /* held, unless a derivative follows */
        if (m->now.phase < CM_STEPPING) continue;
        changed = 1;
        input_changed |= v->kind == KIND_INPUT && m->now.phase == CM_STEPPING;
        /* Co-Simulation: takes effect from the next step. Model Exchange: a tunable also
         * re-derives the mode at the next event update, as a Co-Simulation restart does */
        if (!m->model_exchange || v->kind == KIND_TUNABLE) m->now.pending = 1;
    }
    /* before the end of initialisation a refused exit's reason no longer describes the values: a
     * step now is refused as "not initialised" (cm_cannot), not with a reason the host has mended */
    if (n > 0 && m->now.phase < CM_STEPPING) m->now.failure[0] = 0;
    if (changed && m->model_exchange) {           /* Model Exchange: the values hold from now on */
        cm_load_parameters(m);
        cm_me_evaluate(m);
    } else if (input_changed) {
        /* Co-Simulation: the outputs that depend on an input at once (epsilon1, the accelerations,
         * the reactions; tau_drive in speed causality) are read at the inputs just set, as a master
         * solving a loop by setting and reading expects; the step that follows restarts from them */
        m->now.row_stale = 1;
    }
    return CM_OK;
}

int cm_set_input_derivatives(Model* m, const char* call, const unsigned* vr, size_t n, const int* order,
                             const double* value)
{
    if (m->model_exchange)
        return cm_fail(m, "%s: Co-Simulation only (a Model Exchange host sets the inputs at every time it evaluates)",
                       call);
    if (n > 0 && (!vr || !order || !value)) return cm_fail(m, "%s: null arrays", call);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= (unsigned)m->d->n_variables || m->d->variables[vr[i]].kind != KIND_INPUT)
            return cm_fail(m, "%s: value reference %u is not an input of this FMU", call, vr[i]);
        if (order[i] != 1)
            return cm_fail(m, "%s: %s: order %d; this FMU takes the first derivative only", call, m->d->variables[vr[i]].name,
                           order[i]);
        if (!isfinite(value[i]))
            return cm_fail(m, "%s: %s: the derivative %s must be finite", call, m->d->variables[vr[i]].name,
                           shortest(value[i]).text);
    }
    for (size_t i = 0; i < n; i++) {
        double* rate = &m->now.input_rate[input_index(m, (int)vr[i])];
        if (*rate != value[i] && m->now.phase >= CM_STEPPING) m->now.pending = 1;
        *rate = value[i];
        m->now.rate_given[input_index(m, (int)vr[i])] = 1;
    }
    /* speed causality: omega1's derivative is epsilon1 at once (tau_drive with it) */
    if (n > 0 && m->d->causality_speed && m->now.phase == CM_STEPPING) m->now.row_stale = 1;
    return CM_OK;
}

/* ------------------------------------------------------------------------------ FMU state */

/* a serialized state: a tag (the first 16 characters of the model's GUID inside its braces), then
 * the snapshot's bytes */
enum { STATE_TAG = 16 };

static void state_tag(const Model* m, char tag[STATE_TAG])
{
    const char* guid = m->d->guid;
    memset(tag, 0, STATE_TAG);
    size_t n = strlen(guid);
    if (n > 1) memcpy(tag, guid + 1, n - 1 < STATE_TAG ? n - 1 : STATE_TAG);
}

size_t cm_serialized_size(void) { return STATE_TAG + sizeof(Snapshot); }

void cm_serialize(const Model* m, const Snapshot* s, unsigned char* bytes)
{
    char tag[STATE_TAG];
    state_tag(m, tag);
    memcpy(bytes, tag, STATE_TAG);
    memcpy(bytes + STATE_TAG, s, sizeof(Snapshot));
}

int cm_deserialize(const Model* m, const char* call, const unsigned char* bytes, size_t size, Snapshot* s)
{
    Snapshot read;
    char tag[STATE_TAG];
    state_tag(m, tag);
    /* each refusal says what it judged: the size, the tag, the phase */
    if (!bytes || size != cm_serialized_size())
        return cm_fail(m, "%s: not a serialized state of this FMU: %lu bytes, where its states are %lu", call,
                       (unsigned long)size, (unsigned long)cm_serialized_size());
    if (memcmp(bytes, tag, STATE_TAG) != 0)
        return cm_fail(m, "%s: not a serialized state of this FMU: %lu bytes of the right size, but they do not start "
                       "with its states' tag (another FMU's or another build's state?)", call, (unsigned long)size);
    memcpy(&read, bytes + STATE_TAG, sizeof read);
    if (read.phase < CM_INSTANTIATED || read.phase > CM_FAILED)
        return cm_fail(m, "%s: not a serialized state of this FMU: its phase is %d, not one of %d to %d", call,
                       (int)read.phase, (int)CM_INSTANTIATED, (int)CM_FAILED);
    *s = read;
    return CM_OK;
}

