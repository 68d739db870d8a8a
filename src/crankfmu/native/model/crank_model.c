/* The native mechanism FMU's model (crank_model.h): one file for every scenario, in front of the
 * C kernel (crank_kernel.c) and the C mechanism model (crank_mechanism.c). What a scenario adds is
 * data, written by `crankfmu fmu --native` into the FMU's model file (crank_variables.h, read by
 * crank_model_file.c when an instance is made): its compiled program (the mechanism file's
 * contours, points, links, loads, ports, [[outputs]] and joints as instructions and tables) and its
 * variables' start values and ranges. The tables are built from the program when
 * initialisation ends, at whatever geometry, masses, loads and gravity the host set (each checked
 * as the engine checks it: the assembly over the whole turn, with the angle and the bound of a
 * refusal). Value references: crank_variables.h.
 *
 * Co-Simulation: the kernel steps with rtol and locates every switch inside the step (ck_advance),
 * or stops at the first (ck_advance_to_switch) where the host handles events (FMI 3's event mode
 * and early return).
 * Model Exchange (crank_model_me.c): the host integrates the kernel's y (phi1, omega1 and the three
 * works); the model keeps the mode in the kernel's state array and hands the host the kernel's
 * derivatives, event indicators (with hysteresis) and event update (crank_kernel.h).
 * The variables as a host reads and sets them, and the FMU state as bytes: crank_model_variables.c.
 * Speed causality (the model file's causality_speed): the host imposes omega1, with its derivative
 * where it gives one, and the kernel answers with tau_drive (ck_speed_advance); Co-Simulation only.
 *
 * Failures are loud: every refusal is logged with its reason, NaN and out-of-range values are
 * refused, and a model that failed refuses further steps. Only the tables allocate (their size
 * depends on the design), once per design. */
#include "crank_model_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crank_numbers.h"

int cm_fail(const Model* m, const char* format, ...)
{
    va_list args;
    va_start(args, format);
    cm_refusal(m ? m->log : NULL, m ? m->host : NULL, format, args);
    va_end(args);
    return CM_ERROR;
}

int cm_stop(Model* m, const char* format, ...)
{
    va_list args;
    va_start(args, format);
    vsnprintf(m->now.failure, sizeof m->now.failure, format, args);
    va_end(args);
    return cm_fail(m, "%s", m->now.failure);
}

const char* cm_cannot(const Model* m, const char* call, char* out, size_t n)
{
    if (m->now.failure[0]) return m->now.failure;
    if (m->now.phase == CM_TERMINATED) return "the instance was terminated";
    /* the FMI version's exit call, by the calling function's prefix (fmi2..., fmi3...) */
    snprintf(out, n, "the model is not initialised (call %.4sExitInitializationMode first)",
             strncmp(call, "fmi", 3) == 0 ? call : "fmi2");
    return out;
}

void cm_reset(Model* m)
{
    const ModelData* d = m->d;
    memset(&m->now, 0, sizeof m->now);
    fmu_state_mark(&m->now);             /* every copy of it an FMU state hands out carries it */
    for (int i = 0; i < d->n_variables; i++) m->now.values[i] = d->variables[i].start;
    m->now.time = d->default_start_time;
    m->now.t_limit = INFINITY;
    m->now.event_ahead = -INFINITY;
    m->now.phase = CM_INSTANTIATED;
    m->tables_stale = 1;                 /* the start values: perhaps another design than the tables' */
}

void cm_restore(Model* m, const Snapshot* state)
{
    m->now = *state;
    m->tables_stale = 1;
}

int cm_init(Model* m, const char* call, const ModelData* d, int model_exchange, CmLogger log, void* host)
{
    memset(m, 0, sizeof *m);
    m->model_exchange = model_exchange;
    m->log = log;
    m->host = host;
    m->d = d;
    /* built_for, then the scratch: a design's values and trial values (cm_ensure_tables, bounds),
     * then a read's quantities and reactions (cm_get) */
    size_t parameters = (size_t)d->n_program_parameters + 1;
    size_t reads = (size_t)d->n_quantities + 3 * (size_t)d->n_quantity_coordinates + (size_t)d->n_reactions +
                   (size_t)d->n_reactions * (size_t)d->reaction_terms + (size_t)d->reaction_terms + 4 +
                   (size_t)d->n_friction_outputs + 3 * (size_t)MM_MAX_FRICTIONS + 2;
    m->built_for = (double*)calloc(3 * parameters + reads, sizeof(double));
    if (!m->built_for) {
        cm_free(m);
        return cm_fail(m, "%s: out of memory", call);
    }
    m->scratch = m->built_for + parameters;
    cm_reset(m);
    return CM_OK;
}

void cm_free(Model* m)
{
    cm_release(m);
    free(m->built_for);
    m->built_for = m->scratch = NULL;
}

void cm_release(Model* m)
{
    for (int k = 0; k < CM_TABLES; k++) {
        mm_release(m->cubics[k]);
        m->cubics[k] = NULL;
    }
    free(m->friction_interval_major);
    m->friction_interval_major = NULL;
    m->tables.friction = NULL;
    mm_free(&m->mechanism);
    m->have_tables = 0;
}

/* ------------------------------------------------------------------------------ the tables */

/* the program's parameters from the variables (a parameter the FMU does not declare: its value) */
static void program_parameters(const Model* m, double* out)
{
    for (int i = 0; i < m->d->n_program_parameters; i++)
        out[i] = m->d->program_parameter_vr[i] >= 0 ? m->now.values[m->d->program_parameter_vr[i]] : m->d->program_parameter_value[i];
}

/* the kernel's joint friction (CkFriction) from the friction table and the model's active
 * frictions: the table copied interval-major, each friction's components and c */
static int friction_tables(Model* m)
{
    const mm_model* mm = &m->mechanism;
    const mm_program* p = &m->d->program;
    int rows = mm_rows(mm, MM_TABLE_FRICTION), n = m->intervals[CM_FRICTION];
    if (rows > CK_MAX_FRICTION_FUNCTIONS) return MM_NO_MEMORY;
    m->friction_interval_major = (double*)malloc(sizeof(double) * 4 * (size_t)rows * (size_t)n + 1);
    if (!m->friction_interval_major) return MM_NO_MEMORY;
    const double* in = m->cubics[CM_FRICTION];
    for (int f = 0; f < rows; f++)
        for (int i = 0; i < n; i++)
            memcpy(m->friction_interval_major + 4 * ((size_t)i * rows + f), in + 4 * ((size_t)f * n + i),
                   4 * sizeof(double));
    for (int k = 0; k < mm->n_active; k++) {
        const int* f = p->frictions + 3 * mm->active[k];
        m->friction_components[k] = p->joints[5 * f[0]] ? 1 : 2;
        m->friction_c[k] = mm->registers[f[1]];
    }
    CkFriction friction = {mm->n_active, mm_reaction_terms(mm) - mm->n_active, m->friction_interval_major, n,
                           m->friction_components, m->friction_c, mm->friction_signs};
    m->friction = friction;
    return MM_OK;
}

/* the tables at the values set now: built once per design, again where the values changed */
int cm_ensure_tables(Model* m, const char* call)
{
    if (m->have_tables && !m->tables_stale) return CM_OK;       /* the step's path: one test */
    double* values = m->scratch;            /* its first n_program_parameters + 1 */
    program_parameters(m, values);
    if (m->have_tables) {
        int same = 1;
        for (int k = 0; k < m->d->n_table_parameters && same; k++)
            same = values[m->d->table_parameters[k]] == m->built_for[m->d->table_parameters[k]];
        if (same) {
            m->tables_stale = 0;
            return CM_OK;
        }
    }
    cm_release(m);
    int status = mm_bind(&m->mechanism, &m->d->program, values, m->d->n_program_parameters);
    if (status == MM_OK) status = mm_prepare(&m->mechanism);
    const double tolerance[CM_TABLES] = {m->d->table_tolerance, m->d->table_tolerance, m->d->reaction_tolerance,
                                         m->d->table_tolerance};
    for (int k = 0; k < CM_TABLES && status == MM_OK; k++) {
        /* (the friction table only where some friction is active at these values) */
        const int needed[CM_TABLES] = {1, m->d->n_quantity_coordinates > 0, m->d->n_reactions > 0,
                                       m->mechanism.n_active > 0};
        if (!needed[k]) continue;
        double error;
        int series;
        status = mm_tabulate(&m->mechanism, k, tolerance[k], &m->cubics[k], &m->intervals[k], &error, &series);
    }
    if (status == MM_OK && m->mechanism.n_active > 0) status = friction_tables(m);
    if (status != MM_OK) {
        char text[2048];
        cm_design_refusal(m, call, status, values, text, sizeof text);
        cm_release(m);
        return cm_stop(m, "%s", text);
    }
    memcpy(m->built_for, values, sizeof(double) * m->d->n_program_parameters);
    m->have_tables = 1;
    m->tables_stale = 0;
    m->tables.coefficients = m->cubics[CM_REDUCED];
    m->tables.n_functions = m->d->table_functions;
    m->tables.n = m->intervals[CM_REDUCED];
    m->tables.switch_angles = m->mechanism.switches;
    m->tables.m = m->mechanism.n_switches;
    m->tables.forces = m->mechanism.forces;
    m->tables.n_sliders = m->d->table_sliders;
    m->tables.powers = m->d->column_powers;
    m->tables.law = mm_law;                    /* the program's LAWS section on the bound registers */
    m->tables.law_context = &m->mechanism;
    m->tables.n_ports = m->d->n_ports;
    m->tables.period = m->d->cycle_turns * 6.283185307179586;     /* the machine's cycle (a four-stroke: 2 turns) */
    m->tables.friction = m->mechanism.n_active > 0 ? &m->friction : NULL;
    return CM_OK;
}

int cm_setup(Model* m, const char* call, double start_time, int stop_defined, double stop_time)
{
    if (m->now.phase != CM_INSTANTIATED) return cm_fail(m, "%s is allowed only after instantiation", call);
    if (!isfinite(start_time)) return cm_fail(m, "%s: the start time must be finite", call);
    if (stop_defined && !(stop_time >= start_time)) return cm_fail(m, "%s: the stop time must be >= the start time", call);
    m->now.time = start_time;
    m->now.t_limit = stop_defined ? stop_time : INFINITY;
    return CM_OK;
}

int cm_enter_initialization(Model* m, const char* call)
{
    if (m->now.phase != CM_INSTANTIATED) return cm_fail(m, "%s is allowed only once, after instantiation", call);
    m->now.phase = CM_INITIALIZATION;
    return CM_OK;
}

/* the kernel's parameter array from the variables */
void cm_load_parameters(Model* m)
{
    const double* v = m->now.values;
    const ModelData* d = m->d;
    double* P = m->now.P;
    if (d->causality_speed) {
        memset(P, 0, sizeof m->now.P);             /* no motor line and no tau_ext: the drive is outside */
        P[CK_J_FLYWHEEL] = v[d->vr_j_flywheel];
        for (int i = 0; i < d->n_ports; i++) {
            P[CK_PORT_INPUT + i] = v[d->vr_first_port + i];
            P[CK_PORT_RATE + i] = m->now.input_rate[1 + i];
        }
        P[CK_T_INPUT] = m->now.time;
        return;
    }
    P[CK_A_] = v[d->vr_a];
    P[CK_B_] = v[d->vr_b];
    P[CK_A_LOW] = v[d->vr_a_low];
    P[CK_B_LOW] = v[d->vr_b_low];
    P[CK_OMEGA_SWITCH] = v[d->vr_omega_switch];
    P[CK_TAU_EXT] = v[d->vr_crank_input];
    P[CK_TAU_EXT_RATE] = m->now.input_rate[0];
    for (int i = 0; i < d->n_ports; i++) {
        P[CK_PORT_INPUT + i] = v[d->vr_first_port + i];
        P[CK_PORT_RATE + i] = m->now.input_rate[1 + i];
    }
    /* the inputs are linear in time from the current communication point (Model Exchange: the
     * host sets them at every time it evaluates, and the rates stay 0) */
    P[CK_T_INPUT] = m->model_exchange ? m->now.S[CK_T] : m->now.time;
    P[CK_J_FLYWHEEL] = v[d->vr_j_flywheel];
    P[CK_RTOL] = v[d->vr_rtol];
    P[CK_ATOL] = v[d->vr_rtol];
    P[CK_H_MAX] = INFINITY;
}

/* the crank's speed at the start: omega1_start, or the input omega1 in speed causality */
static double start_speed(const Model* m)
{
    return m->now.values[m->d->causality_speed ? m->d->vr_crank_input : m->d->vr_omega1_start];
}

/* whether a variable sets the initial state (variability fixed: before the end of initialisation) */
int cm_sets_initial_state(const Model* m, int vr)
{
    /* (speed causality: vr_omega1_start is -1) */
    return vr == m->d->vr_phi1_start || vr == m->d->vr_omega1_start;
}

static int outputs_finite(const Model* m)
{
    for (int j = 0; j < CK_OUT_SIZE; j++)
        if (!isfinite(m->now.row[j])) return 0;
    return 1;
}

/* Model Exchange: the state and mode at the start (the initial state is the start values) */
void cm_me_start(Model* m)
{
    cm_load_parameters(m);
    double* S = m->now.S;
    memset(S, 0, sizeof m->now.S);
    S[CK_T] = m->now.time;
    S[CK_Y] = m->now.values[m->d->vr_phi1_start];
    S[CK_Y + 1] = start_speed(m);
    ck_me_mode(S, S + CK_Y, &m->tables, m->now.P);
}

/* Model Exchange: derivatives and outputs at the current state; 1 when they are finite */
int cm_me_evaluate(Model* m)
{
    if (ck_me_derivatives(m->now.S, m->now.S + CK_Y, &m->tables, m->now.P, m->now.dydt, m->now.row) != 0) return 0;
    for (int j = 0; j < m->d->n_states; j++)
        if (!isfinite(m->now.dydt[j])) return 0;
    return outputs_finite(m);
}

/* Co-Simulation: the kernel's state and the output row at the start */
void cm_cs_start(Model* m)
{
    cm_load_parameters(m);
    memset(m->now.S, 0, sizeof m->now.S);
    m->now.event_ahead = -INFINITY;
    if (m->d->causality_speed) {
        ck_speed_begin(m->now.S, m->now.time, m->now.values[m->d->vr_phi1_start], start_speed(m), &m->tables,
                       m->now.P, m->now.row);
        return;
    }
    double y[CK_N_Y] = {m->now.values[m->d->vr_phi1_start], start_speed(m), 0.0, 0.0, 0.0};
    ck_begin(m->now.S, m->now.time, y, &m->tables, m->now.P, m->now.row);
}

/* the outputs an initial state was judged by, by their declared names (m->d->variables, m->d->output_row: the
 * generated tables), for a refusal's message (as the Python FMU's) */
static const char* judged_row(const Model* m, char* out, size_t n)
{
    size_t used = 0;
    out[0] = 0;
    for (int vr = 0; vr < m->d->n_outputs && used + 48 < n; vr++)
        if (m->d->output_row[vr] >= 0)
            used += (size_t)snprintf(out + used, n - used, "%s%s = %g", used ? ", " : "", m->d->variables[vr].name,
                                     m->now.row[m->d->output_row[vr]]);
    return out;
}

int cm_exit_initialization(Model* m, const char* call)
{
    if (m->now.phase != CM_INITIALIZATION) return cm_fail(m, "%s without entering initialisation mode", call);
    /* refused: the instance stays in initialisation, for other values or a reset */
    char refused[sizeof m->now.failure];
    if (m->now.n_refused)
        return cm_stop(m, "%s: cannot initialise: %s", call, cm_refusals(m, refused, sizeof refused));
    if (cm_ensure_tables(m, call) != CM_OK) {
        /* its message said already (with the call's name): kept for the calls that follow */
        return CM_ERROR;
    }
    int finite;
    if (m->model_exchange) {
        cm_me_start(m);
        finite = cm_me_evaluate(m);
    } else {
        cm_cs_start(m);
        finite = outputs_finite(m);
    }
    if (!finite) {
        char judged[512];
        m->now.phase = CM_FAILED;
        return cm_stop(m, "%s: the initial state gives non-finite %s (%s): check the parameters", call,
                       m->model_exchange ? "derivatives or outputs" : "outputs", judged_row(m, judged, sizeof judged));
    }
    m->now.failure[0] = 0;
    m->now.phase = CM_STEPPING;
    m->now.pending = 0;
    return CM_OK;
}

void cm_terminate(Model* m) { m->now.phase = CM_TERMINATED; }

/* restart the kernel at the current time (a tunable or the input changed), keeping its step size */
static void restart(Model* m)
{
    double y[CK_N_Y];
    ck_dense(m->now.S, m->now.time, y);
    double h = m->now.S[CK_H], n_rhs = m->now.S[CK_N_RHS], n_steps = m->now.S[CK_N_STEPS];
    cm_load_parameters(m);
    memset(m->now.S, 0, sizeof m->now.S);
    ck_begin(m->now.S, m->now.time, y, &m->tables, m->now.P, m->now.row);
    m->now.S[CK_H] = h;
    m->now.S[CK_N_RHS] += n_rhs;
    m->now.S[CK_N_STEPS] = n_steps;
    m->now.pending = 0;
    m->now.event_ahead = -INFINITY;
}

/* a torque-causal step from t to target, its switches as cm_do_step says; the kernel's status */
static int torque_step(Model* m, double t, double* target_io, int switches, int* stopped)
{
    double target = *target_io;
    int status = 0;
    if (m->now.pending) restart(m);
    double t_limit = fmax(m->now.t_limit, target);
    if (switches == CM_SWITCHES_INSIDE) {
        status = ck_advance(m->now.S, target, t_limit, &m->tables, m->now.P, m->now.row);
        m->now.event_ahead = -INFINITY;
    } else {
        /* a switch the kernel's last step located past the last communication point is in this step
         * if it is not past its end */
        if (m->now.event_ahead > t && m->now.event_ahead <= target) {
            *stopped = 1;
            if (switches == CM_SWITCHES_STOP) target = m->now.event_ahead;
            m->now.event_ahead = -INFINITY;
        }
        long located = 0;
        while (status == 0 && !(*stopped && switches == CM_SWITCHES_STOP)) {
            if (++located > CK_MAX_STEPS_PER_CALL / 10) {          /* each a kernel step at least */
                status = CK_TOO_MANY_STEPS;
                break;
            }
            double t_switch = target;
            status = ck_advance_to_switch(m->now.S, target, t_limit, &m->tables, m->now.P, m->now.row, &t_switch);
            if (status != 1) break;                       /* at target (0), or refused */
            status = 0;
            if (t_switch > target) {                      /* past this step: the next one's */
                m->now.event_ahead = t_switch;
                break;
            }
            *stopped = 1;
            if (switches == CM_SWITCHES_STOP) target = t_switch;
            else if (m->now.S[CK_T] >= target) break;     /* a switch exactly at the end */
        }
        if (status == 0 && !(m->now.S[CK_T] >= target)) status = CK_BAD_STATE;
        if (status == 0) status = ck_advance(m->now.S, target, target, &m->tables, m->now.P, m->now.row);
    }
    *target_io = target;
    return status;
}

int cm_do_step(Model* m, const char* call, double t_host, double h, int switches, double* t_end, int* stopped)
{
    *stopped = 0;
    *t_end = m->now.time;
    if (m->model_exchange) return cm_fail(m, "%s: this instance is Model Exchange", call);
    if (m->now.phase != CM_STEPPING) {
        char why[160];
        return cm_fail(m, "%s: cannot step: %s", call, cm_cannot(m, call, why, sizeof why));
    }
    if (m->now.n_refused) {            /* a value refused while stepping: the host corrects it first */
        char refused[sizeof m->now.failure];
        return cm_fail(m, "%s: cannot step: %s", call, cm_refusals(m, refused, sizeof refused));
    }
    if (!isfinite(t_host) || !isfinite(h) || !(h > 0.0))
        return cm_fail(m, "%s needs a finite current time and a finite step size > 0", call);
    if (cm_ensure_tables(m, call) != CM_OK) {                    /* an FMU state of another design */
        m->now.phase = CM_FAILED;
        return CM_ERROR;
    }
    double t = m->now.time;
    if (fabs(t_host - t) > 1e-9 * fmax(1.0, fabs(t)) + 1e-6 * h)
        return cm_fail(m, "%s at t = %s s, but this instance is at t = %s s", call, shortest(t_host).text,
                       shortest(t).text);
    /* the step ends on the host's clock, as the Python FMUs' does: an instance's own sum of steps
     * can drift from it by an ulp, which the speed step (h enters its line) would carry on */
    double target = t_host + h;
    if (!(target > t)) target = t + h;
    int status;
    if (m->d->causality_speed) {
        /* the inputs as set now: the ports' held (or linear, with their rates) from t, omega1 a line */
        cm_load_parameters(m);
        status = ck_speed_advance(m->now.S, target, m->now.values[m->d->vr_crank_input], m->now.input_rate[0],
                                  m->now.rate_given[0], &m->tables, m->now.P, m->now.row);
    } else {
        status = torque_step(m, t, &target, switches, stopped);
    }
    if (status != 0 || !outputs_finite(m)) {
        m->now.phase = CM_FAILED;
        return cm_stop(m, "%s: step from t = %g s failed: %s at t = %.9g s", call, t_host,
                       m->d->causality_speed ? "non-finite values, or a step of over 1e9 degrees of crank angle"
                       : status == 0         ? "non-finite outputs"
                                             : ck_status_text(status),
                       m->now.S[CK_T]);
    }
    m->now.time = target;
    m->now.row_stale = 0;                /* the step wrote the row */
    *t_end = target;
    return CM_OK;
}
