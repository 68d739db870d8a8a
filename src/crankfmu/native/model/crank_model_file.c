/* A native FMU's model file (crank_variables.h): found in the resources a host gives, its SHA-256
 * checked, read into a ModelData, and checked for what the model relies on (a mechanism's: each
 * variable where its value reference says, of the kind it is there; every index the program and
 * the tables hold inside what it indexes). Every refusal names the file and what was wrong with it.
 *
 * The digest is what tells an altered file from the one the build wrote: any change of a byte of
 * the payload is refused before it is read. The reads are bounded all the same, so that even a
 * file whose digest was made to match cannot make the reader step outside the file. */
#include "crank_variables.h"
#include "sha256.h"

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------ reading */

typedef struct {
    const unsigned char* at;
    size_t left;
    const char* file;
    const char* what;            /* what is being read, for a refusal */
    ModelData* d;
    char* why;
    size_t why_size;
    int failed;
} Reader;

static void refuse(Reader* r, const char* format, ...)
{
    if (r->failed) return;
    r->failed = 1;
    size_t used = (size_t)snprintf(r->why, r->why_size, "the model file %s ", r->file);
    va_list args;
    va_start(args, format);
    if (used < r->why_size) vsnprintf(r->why + used, r->why_size - used, format, args);
    va_end(args);
}

static void* keep(Reader* r, size_t size)
{
    ModelData* d = r->d;
    if (d->n_blocks == d->blocks_size) {
        int grown = d->blocks_size ? 2 * d->blocks_size : 64;
        void** blocks = (void**)realloc(d->blocks, (size_t)grown * sizeof(void*));
        if (!blocks) return NULL;
        d->blocks = blocks;
        d->blocks_size = grown;
    }
    void* block = calloc(1, size ? size : 1);
    if (block) d->blocks[d->n_blocks++] = block;
    return block;
}

static const unsigned char* take(Reader* r, size_t n)
{
    if (r->failed) return NULL;
    if (n > r->left) {
        refuse(r, "is not whole: it ends inside %s", r->what);
        return NULL;
    }
    const unsigned char* p = r->at;
    r->at += n;
    r->left -= n;
    return p;
}

static uint32_t u32(const unsigned char* p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }

static int read_int(Reader* r, const char* what)
{
    r->what = what;
    const unsigned char* p = take(r, 4);
    return p ? (int)(int32_t)u32(p) : 0;
}

static double read_double(Reader* r, const char* what)
{
    r->what = what;
    const unsigned char* p = take(r, 8);
    if (!p) return 0.0;
    uint64_t bits = (uint64_t)u32(p) | (uint64_t)u32(p + 4) << 32;
    double x;
    memcpy(&x, &bits, sizeof x);
    return x;
}

/* a count, checked against what is left of the file (each item at least ``item`` bytes) */
static int read_count(Reader* r, const char* what, size_t item)
{
    int n = read_int(r, what);
    if (!r->failed && (n < 0 || (size_t)n > r->left / (item ? item : 1)))
        refuse(r, "is damaged: %s counts %d items, more than its remaining %lu bytes hold", what, n,
               (unsigned long)r->left);
    return r->failed ? 0 : n;
}

static const char* read_string(Reader* r, const char* what)
{
    int n = read_count(r, what, 1);
    const unsigned char* p = take(r, (size_t)n);
    char* s = p ? (char*)keep(r, (size_t)n + 1) : NULL;
    if (!s) {
        if (!r->failed) refuse(r, "could not be read: out of memory");
        return "";
    }
    memcpy(s, p, (size_t)n);
    if (memchr(s, 0, (size_t)n)) refuse(r, "is damaged: %s holds a NUL byte", what);
    return s;
}

/* an array's count (each item at least ``item`` bytes in the file) and its memory (``size`` bytes
 * each); NULL, *count 0, where the file or the memory fails */
static void* read_array(Reader* r, const char* what, size_t item, size_t size, int* count)
{
    int n = read_count(r, what, item);
    void* a = r->failed ? NULL : keep(r, (size_t)n * size);
    if (!a && !r->failed) refuse(r, "could not be read: out of memory");
    *count = a ? n : 0;
    return a;
}

static const int* read_ints(Reader* r, const char* what, int* count)
{
    int* a = (int*)read_array(r, what, 4, sizeof(int), count);
    for (int i = 0; i < *count; i++) a[i] = read_int(r, what);
    return a;
}

static const double* read_doubles(Reader* r, const char* what, int* count)
{
    double* a = (double*)read_array(r, what, 8, sizeof(double), count);
    for (int i = 0; i < *count; i++) a[i] = read_double(r, what);
    return a;
}

static const char* const* read_strings(Reader* r, const char* what, int* count)
{
    const char** a = (const char**)read_array(r, what, 4, sizeof(char*), count);
    for (int i = 0; i < *count; i++) a[i] = read_string(r, what);
    return a;
}

/* ------------------------------------------------------------------------------ checking */

static int within(Reader* r, const char* what, const int* a, int n, int low, int high)
{
    for (int i = 0; i < n && !r->failed; i++)
        if (a[i] < low || a[i] >= high) refuse(r, "is damaged: %s[%d] = %d is outside [%d, %d)", what, i, a[i], low, high);
    return !r->failed;
}

static void expect_count(Reader* r, const char* what, int n, int expected)
{
    if (!r->failed && n != expected) refuse(r, "is damaged: %d %s where its counts say %d", n, what, expected);
}

/* the value references the counts give, each checked to be the variable the model takes it for */
static void place_variables(Reader* r)
{
    ModelData* d = r->d;
    static const char* const TORQUE[] = {"A", "B", "A_low", "B_low", "omega_switch", "J_flywheel", "phi1_start",
                                         "omega1_start", "rtol"};
    static const char* const SPEED[] = {"J_flywheel", "phi1_start"};
    const char* const* tunable = d->causality_speed ? SPEED : TORQUE;
    int n_tunable = d->causality_speed ? 2 : 9;
    d->vr_crank_input = d->n_outputs;
    int* places[] = {&d->vr_a, &d->vr_b, &d->vr_a_low, &d->vr_b_low, &d->vr_omega_switch, &d->vr_j_flywheel,
                     &d->vr_phi1_start, &d->vr_omega1_start, &d->vr_rtol};
    for (int k = 0; k < 9; k++) *places[k] = -1;
    for (int k = 0; k < n_tunable; k++) {
        int vr = d->vr_crank_input + 1 + k;
        for (int p = 0; p < 9; p++)
            if (strcmp(TORQUE[p], tunable[k]) == 0) *places[p] = vr;
    }
    d->vr_first_fixed = d->vr_crank_input + 1 + n_tunable;
    d->vr_first_quantity = d->vr_first_fixed + d->n_fixed;
    d->vr_first_derivative = d->vr_first_quantity + d->n_quantities;
    d->n_states = d->program.n_frictions > 0 ? CK_N_Y : CK_N_PLAIN;      /* W_friction with friction */
    d->n_derivatives = d->causality_speed ? 0 : d->n_states;
    d->vr_first_port = d->vr_first_derivative + d->n_derivatives;
    d->vr_first_reaction = d->vr_first_port + d->n_ports;
    d->vr_first_friction = d->vr_first_reaction + d->n_reactions;
    d->n_friction_outputs = d->program.n_frictions > 0 ? FRICTION_JOINTS + 2 * d->program.n_frictions : 0;
    d->n_inputs = 1 + d->n_ports;
    expect_count(r, "variables", d->n_variables, d->vr_first_friction + d->n_friction_outputs);
    if (r->failed) return;
    for (int vr = 0; vr < d->n_variables && !r->failed; vr++) {
        int kind = vr < d->vr_crank_input ? KIND_OUTPUT
                 : vr == d->vr_crank_input ? KIND_INPUT
                 : vr < d->vr_first_fixed ? KIND_TUNABLE
                 : vr < d->vr_first_quantity ? KIND_FIXED
                 : vr < d->vr_first_derivative ? KIND_QUANTITY
                 : vr < d->vr_first_port ? KIND_DERIVATIVE
                 : vr < d->vr_first_reaction ? KIND_INPUT
                 : vr < d->vr_first_friction ? KIND_REACTION : KIND_FRICTION;
        if (d->variables[vr].kind != kind)
            refuse(r, "is damaged: variable %d (%s) is of kind %d where kind %d belongs", vr, d->variables[vr].name,
                   d->variables[vr].kind, kind);
        else if (kind == KIND_TUNABLE && strcmp(d->variables[vr].name, tunable[vr - d->vr_crank_input - 1]) != 0)
            refuse(r, "is damaged: variable %d is %s where %s belongs", vr, d->variables[vr].name,
                   tunable[vr - d->vr_crank_input - 1]);
    }
}

/* a table of rows of ``width`` ints: its count of rows (mm_program's n_...) from its count of ints */
static int rows_of(Reader* r, const char* what, int ints, int width)
{
    if (!r->failed && ints % width) refuse(r, "is damaged: %s holds %d ints, not rows of %d", what, ints, width);
    return ints / width;
}

/* the program's instructions and tables index only what exists (crank_mechanism.h's layout) */
static void check_program(Reader* r, int n_literals)
{
    mm_program* p = &r->d->program;
    int regs = p->n_registers;
    /* (the tables were read as ints: their rows, as the model counts them) */
    p->n_code = rows_of(r, "the code", p->n_code, 5);
    p->n_sections = rows_of(r, "the sections", p->n_sections, 2);
    p->n_terms = rows_of(r, "the terms", p->n_terms, MM_TERM_FIELDS);
    p->n_angles = rows_of(r, "the angles", p->n_angles, 2);
    p->n_searches = rows_of(r, "the searches", p->n_searches, MM_SEARCH_FIELDS);
    p->n_coordinates = rows_of(r, "the coordinates", p->n_coordinates, 4);
    p->n_links = rows_of(r, "the links", p->n_links, 5);
    p->n_joints = rows_of(r, "the joints", p->n_joints, 5);
    p->n_terms_reaction = rows_of(r, "the reaction terms", p->n_terms_reaction, 2);
    p->n_applied = rows_of(r, "the applied loads", p->n_applied, 6);
    if (r->failed) return;
    if (regs < 1 || p->n_sections < MM_FIRST_SEARCH + p->n_searches || p->n_q < 1 || p->n_chains < 0 ||
        p->n_contours < 0 || p->n_points < 0) {
        refuse(r, "is damaged: its program's sizes do not fit together");
        return;
    }
    for (int i = 0; i < p->n_code && !r->failed; i++) {
        const int* c = p->code + 5 * i;
        if (c[0] < 0 || c[0] >= MM_N_OPS) refuse(r, "is damaged: instruction %d has no operation %d", i, c[0]);
        else if (within(r, "an instruction's operands", c + 1, 4, 0, regs) && c[0] == MM_LITERAL && c[2] >= n_literals)
            refuse(r, "is damaged: instruction %d reads literal %d of %d", i, c[2], n_literals);
    }
    within(r, "the program's sections", p->sections, 2 * p->n_sections, 0, p->n_code + 1);
    for (int s = 0; s < p->n_sections && !r->failed; s++)
        if (p->sections[2 * s] > p->sections[2 * s + 1]) refuse(r, "is damaged: section %d ends before it starts", s);
    within(r, "the table's rows", p->rows, p->n_rows, 0, regs);
    within(r, "the table's columns", p->columns, p->n_columns, 0, regs);
    within(r, "the laws of the speed", p->laws, p->n_columns, -1, regs);
    within(r, "the law's speed", &p->law_speed, 1, -1, regs);
    within(r, "the checks", p->checks, p->n_checks, 0, regs);
    int q = p->n_q;
    int registers_per_angle = p->kinematics + 3 * (q - 1) + 6 * p->n_points;
    if (!r->failed && (p->phi1 < 0 || p->phi1 >= regs || p->kinematics < 0 || registers_per_angle > regs ||
                       p->guess < -1 || p->guess + q > regs || p->omega1 < 0 || p->omega1 >= regs ||
                       p->n_chains != p->n_contours + p->n_points || 2 * p->n_contours != q - 1))
        refuse(r, "is damaged: its program's registers do not hold its kinematics");
    within(r, "the terms", p->terms, MM_TERM_FIELDS * p->n_terms, -1, regs);
    within(r, "the angles", p->angles, 2 * p->n_angles, -1, regs);
    within(r, "the searches", p->searches, MM_SEARCH_FIELDS * p->n_searches, -1, regs);
    within(r, "the coordinates", p->coordinates, 4 * p->n_coordinates, -1, regs);
    within(r, "the links", p->links, 5 * p->n_links, -1, regs);
    within(r, "the joints", p->joints, 5 * p->n_joints, -1, regs);
    within(r, "the reaction terms", p->term_inertia, 2 * p->n_terms_reaction, -1, regs);
    within(r, "the applied loads", p->applied, 6 * p->n_applied, -1, regs);
    if (!r->failed && (p->n_frictions > MM_MAX_FRICTIONS || p->n_frictions > p->n_terms_reaction))
        refuse(r, "has %d joint frictions; this binary takes at most %d", p->n_frictions, MM_MAX_FRICTIONS);
    for (int i = 0; i < p->n_frictions && !r->failed; i++) {
        const int* f = p->frictions + 3 * i;
        if (f[0] < 0 || f[0] >= p->n_joints) refuse(r, "is damaged: joint friction %d's joint is out of range", i);
        else within(r, "the joint frictions' registers", f + 1, 2, 0, regs);
    }
    for (int s = 0; s < p->n_searches && !r->failed; s++) {
        const int* f = p->searches + MM_SEARCH_FIELDS * s;
        if (f[0] == MM_FRICTION_RATE && (f[3] < 0 || f[3] >= p->n_frictions))
            refuse(r, "is damaged: search %d's joint friction is out of range", s);
    }
    for (int t = 0; t < p->n_terms && !r->failed; t++)
        if (p->terms[MM_TERM_FIELDS * t] < 0 || p->terms[MM_TERM_FIELDS * t] >= p->n_chains)
            refuse(r, "is damaged: term %d's chain is out of range", t);
}

/* the variables' table (every kind's) */
static void read_variables(Reader* r)
{
    ModelData* d = r->d;
    d->n_variables = read_count(r, "the variables", 52);
    Variable* variables = r->failed ? NULL : (Variable*)keep(r, (size_t)d->n_variables * sizeof(Variable));
    for (int i = 0; variables && i < d->n_variables && !r->failed; i++) {
        Variable* v = &variables[i];
        v->name = read_string(r, "a variable's name");
        v->kind = read_int(r, "a variable");
        v->start = read_double(r, "a variable");
        v->has_min = read_int(r, "a variable");
        v->min_inclusive = read_int(r, "a variable");
        v->has_max = read_int(r, "a variable");
        v->max_inclusive = read_int(r, "a variable");
        v->min = read_double(r, "a variable");
        v->max = read_double(r, "a variable");
        v->range = read_string(r, "a variable's range");
        v->unit = read_string(r, "a variable's unit");
        v->description = read_string(r, "a variable's description");
        if (!r->failed && (v->kind < 0 || v->kind >= KIND_COUNT)) refuse(r, "is damaged: variable %d's kind is %d", i, v->kind);
    }
    d->variables = variables;
    if (!r->failed && d->n_variables > CM_MAX_VARIABLES)
        refuse(r, "has %d variables; this binary takes at most %d", d->n_variables, CM_MAX_VARIABLES);
}

/* a mechanism's payload after the variables, in fmi/native/model_file.py's order */
static void read_mechanism(Reader* r)
{
    ModelData* d = r->d;
    d->mechanism_name = read_string(r, "the mechanism's name");
    d->mechanism_branch = read_string(r, "the mechanism's branch");
    int* ints[] = {&d->causality_speed, &d->cycle_turns, &d->n_outputs, &d->n_fixed, &d->n_quantities, &d->n_ports,
                   &d->n_reactions, &d->reaction_terms, &d->n_quantity_coordinates, &d->table_functions,
                   &d->table_sliders, &d->vr_e_kin};
    for (size_t k = 0; k < sizeof ints / sizeof ints[0]; k++) *ints[k] = read_int(r, "the counts");
    d->table_tolerance = read_double(r, "the tolerances");
    d->reaction_tolerance = read_double(r, "the tolerances");
    int n_output_row, n_coordinate, n_order, n_literals;
    d->output_row = read_ints(r, "the output row", &n_output_row);
    d->quantity_coordinate = read_ints(r, "the [[outputs]]' coordinates", &n_coordinate);
    d->quantity_order = read_ints(r, "the [[outputs]]' orders", &n_order);
    /* the program (dynamics/program.py), in native/mechanism.py's order of mm_program's fields */
    mm_program* p = &d->program;
    p->n_registers = read_int(r, "the program");
    p->literals = read_doubles(r, "the program's literals", &n_literals);
    p->code = read_ints(r, "the program's code", &p->n_code);
    p->sections = read_ints(r, "the program's sections", &p->n_sections);
    p->terms = read_ints(r, "the program's terms", &p->n_terms);
    p->angles = read_ints(r, "the program's angles", &p->n_angles);
    int n_chain_constants, n_angle_column;
    p->chain_constants = read_ints(r, "the program's chains", &n_chain_constants);
    p->angle_column = read_ints(r, "the program's angle columns", &n_angle_column);
    p->rows = read_ints(r, "the program's rows", &p->n_rows);
    p->columns = read_ints(r, "the program's columns", &p->n_columns);
    p->searches = read_ints(r, "the program's searches", &p->n_searches);
    p->checks = read_ints(r, "the program's checks", &p->n_checks);
    p->coordinates = read_ints(r, "the program's coordinates", &p->n_coordinates);
    p->links = read_ints(r, "the program's links", &p->n_links);
    p->joints = read_ints(r, "the program's joints", &p->n_joints);
    p->term_inertia = read_ints(r, "the program's reaction terms", &p->n_terms_reaction);
    p->applied = read_ints(r, "the program's applied loads", &p->n_applied);
    int n_powers, n_laws;
    d->column_powers = read_ints(r, "the program's column powers", &n_powers);
    p->laws = read_ints(r, "the program's laws of the speed", &n_laws);
    int n_friction_ints;
    p->frictions = read_ints(r, "the program's joint frictions", &n_friction_ints);
    p->n_frictions = rows_of(r, "the joint frictions", n_friction_ints, 3);
    int* scalars[] = {&p->n_q, &p->n_contours, &p->n_chains, &p->closed_form, &p->guess, &p->phi1, &p->kinematics,
                      &p->n_points, &p->omega1, &p->crank, &p->cycle_turns, &p->law_speed};
    for (size_t k = 0; k < sizeof scalars / sizeof scalars[0]; k++) *scalars[k] = read_int(r, "the program");
    p->min_conditioning = read_double(r, "the program");
    int n_vr, n_value, n_name;
    d->program_parameter_vr = read_ints(r, "the program's parameters", &n_vr);
    d->program_parameter_value = read_doubles(r, "the program's parameters", &n_value);
    d->program_parameter_name = read_strings(r, "the program's parameters", &n_name);
    d->n_program_parameters = n_vr;
    d->check_names = read_strings(r, "the checks' names", &d->n_check_names);
    d->geometry_parameters = read_ints(r, "the geometry parameters", &d->n_geometry_parameters);
    d->table_parameters = read_ints(r, "the table's parameters", &d->n_table_parameters);
    d->unknown_names = read_strings(r, "the unknowns' names", &d->n_unknown_names);
    if (!r->failed && r->left) refuse(r, "is damaged: %lu bytes follow its model", (unsigned long)r->left);
    /* what the model relies on */
    if (!r->failed && (d->n_outputs < 1 || d->n_fixed < 0 || d->n_quantities < 0 || d->n_reactions < 0 ||
                       d->n_quantity_coordinates < 0 || d->reaction_terms < 1 || d->table_functions < 1 ||
                       d->table_functions > CK_MAX_FUNCTIONS ||
                       d->table_sliders < 0 || d->cycle_turns < 1 || d->cycle_turns > 8 || p->cycle_turns != d->cycle_turns ||
                       (d->causality_speed != 0 && d->causality_speed != 1)))
        refuse(r, "is damaged: its counts are out of range");
    if (!r->failed && (d->n_ports < 0 || d->n_ports > CK_MAX_PORTS))
        refuse(r, "has %d ports; this binary takes at most %d", d->n_ports, CK_MAX_PORTS);
    if (!r->failed) place_variables(r);
    expect_count(r, "output places", n_output_row, d->n_outputs);
    within(r, "the output row", d->output_row, n_output_row, -1, CK_OUT_SIZE);
    if (!r->failed && (d->vr_e_kin < 0 || d->vr_e_kin >= d->n_outputs)) refuse(r, "is damaged: E_kin's place");
    expect_count(r, "coordinates of [[outputs]]", n_coordinate, d->n_quantities);
    expect_count(r, "orders of [[outputs]]", n_order, d->n_quantities);
    within(r, "the [[outputs]]' coordinates", d->quantity_coordinate, n_coordinate, 0, d->n_quantity_coordinates);
    within(r, "the [[outputs]]' orders", d->quantity_order, n_order, 0, 3);

    expect_count(r, "table rows", p->n_rows, d->table_functions);
    expect_count(r, "table columns", p->n_columns, d->table_sliders);
    expect_count(r, "column powers", n_powers, p->n_columns);
    within(r, "the column powers", d->column_powers, n_powers, 0, CK_LAW + 1);
    expect_count(r, "laws of the speed", n_laws, p->n_columns);
    expect_count(r, "chain constants", n_chain_constants, 2 * p->n_chains);
    expect_count(r, "angle columns", n_angle_column, p->n_q);
    expect_count(r, "parameter values", n_value, d->n_program_parameters);
    expect_count(r, "parameter names", n_name, d->n_program_parameters);
    expect_count(r, "check names", d->n_check_names, p->n_checks);
    expect_count(r, "unknowns' names", d->n_unknown_names, p->n_q - 1);
    within(r, "the parameters' value references", d->program_parameter_vr, n_vr, -1, d->n_variables);
    within(r, "the geometry parameters", d->geometry_parameters, d->n_geometry_parameters, 0, d->n_program_parameters);
    within(r, "the table's parameters", d->table_parameters, d->n_table_parameters, 0, d->n_program_parameters);
    if (!r->failed && d->n_program_parameters > p->n_registers) refuse(r, "is damaged: more parameters than registers");
    check_program(r, n_literals);
    expect_count(r, "coordinates of the program", p->n_coordinates, d->n_quantity_coordinates);
}

/* a component's payload is its variables: each an output, an input, a parameter or a state's
 * derivative (the model finds the ones it needs by name when an instance is made) */
static void read_component(Reader* r)
{
    ModelData* d = r->d;
    if (!r->failed && r->left) refuse(r, "is damaged: %lu bytes follow its model", (unsigned long)r->left);
    for (int vr = 0; vr < d->n_variables && !r->failed; vr++)
        if (d->variables[vr].kind > KIND_FIXED && d->variables[vr].kind != KIND_DERIVATIVE)
            refuse(r, "is damaged: variable %d (%s) is of kind %d, which no component has", vr, d->variables[vr].name,
                   d->variables[vr].kind);
}

ModelData* md_parse(const unsigned char* bytes, size_t size, const char* file, char* why, size_t why_size)
{
    ModelData* d = (ModelData*)calloc(1, sizeof(ModelData));
    Reader r0 = {bytes, size, file, "its header", d, why, why_size, 0};
    Reader* r = &r0;
    if (!d) {
        snprintf(why, why_size, "the model file %s could not be read: out of memory", file);
        return NULL;
    }
    /* the header: magic, format, kind, the payload's size and digest */
    const unsigned char* magic = take(r, 16);
    if (magic && memcmp(magic, CM_MODEL_MAGIC, 16) != 0) refuse(r, "is not a crankfmu model file (its first bytes)");
    int format = read_int(r, "its header");
    d->kind = read_int(r, "its header");
    if (!r->failed && format != CM_MODEL_FORMAT)
        refuse(r, "is of format %d; this FMU's binary reads format %d (rebuild the FMU with the crankfmu that built "
               "its binary)", format, CM_MODEL_FORMAT);
    if (!r->failed && (d->kind < CM_MODEL_MECHANISM || d->kind >= CM_MODEL_KINDS))
        refuse(r, "is of kind %d; this binary runs kinds %d to %d", d->kind, CM_MODEL_MECHANISM, CM_MODEL_KINDS - 1);
    const unsigned char* sized = take(r, 8);
    const unsigned char* digest = take(r, 32);
    if (!r->failed) {
        uint64_t payload = (uint64_t)u32(sized) | (uint64_t)u32(sized + 4) << 32;
        unsigned char found[32];
        if (payload != r->left) {
            refuse(r, "is %s: its header says %llu bytes of model, it holds %lu", payload > r->left ? "truncated" : "not whole",
                   (unsigned long long)payload, (unsigned long)r->left);
        } else {
            sha256(r->at, r->left, found);
            if (memcmp(found, digest, 32) != 0)
                refuse(r, "was altered: its SHA-256 is not the one its header records (rebuild the FMU)");
        }
    }
    /* the payload, in fmi/native/model_file.py's order: every kind's, then the kind's own */
    d->identifier = read_string(r, "the identifier");
    d->guid = read_string(r, "the GUID");
    d->default_start_time = read_double(r, "the start time");
    read_variables(r);
    if (d->kind == CM_MODEL_MECHANISM) read_mechanism(r);
    else read_component(r);
    if (r->failed) {
        md_free(d);
        return NULL;
    }
    return d;
}

void md_free(ModelData* d)
{
    if (!d) return;
    for (int i = 0; i < d->n_blocks; i++) free(d->blocks[i]);
    free(d->blocks);
    free(d);
}
