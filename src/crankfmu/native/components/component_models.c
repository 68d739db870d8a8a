/* The native component FMUs' models: the drive (torque out, speed in), the drive in speed causality
 * (it carries the rotor: speed out, the mechanism's torque in), the die cushion, the elastic shaft
 * and the rod string,
 * each on the components' physics (crank_components.c). The model file says which one an FMU is
 * (its kind) and what its variables are; each model finds the variables it uses by their names,
 * which the data files require (dynamics/drive.py, dynamics/cushion.py, dynamics/shaft.py,
 * dynamics/well.py). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "component_model.h"
#include "crank_components.h"

/* the names each kind uses, in its slots' order (c->slot[k] is the value reference of name k) */
enum { DR_R, DR_L, DR_K_T, DR_N_GEAR, DR_KP, DR_KI, DR_OMEGA, DR_OMEGA_SET, DR_I_START, DR_X_START, DR_TAU, DR_I, DR_U,
       DR_P_EL, DR_X, DR_OMEGA_START, DR_TAU_LOAD, DR_J_DRIVE, DR_DER_I, DR_DER_X, DR_DER_OMEGA };
static const char* const DRIVE[] = {"R", "L", "k_t", "n_gear", "Kp", "Ki", "omega", "omega_set", "i_start", "x_start",
                                    "tau", "i", "u", "P_el", "x", "omega_start", "tau_load", "J_drive",
                                    "der(i)", "der(x)", "der(omega)"};
/* the drive's states, in its state array's order (each is an output), and their rates' variables */
static const int DRIVE_STATE[] = {DR_I, DR_X, DR_OMEGA};
static const int DRIVE_RATE[] = {DR_DER_I, DR_DER_X, DR_DER_OMEGA};
enum { CU_K, CU_C, CU_L_FREE, CU_S_SEAT, CU_S, CU_V, CU_F };
static const char* const CUSHION[] = {"k", "c", "L_free", "s_seat", "s", "v", "F"};
/* the elastic shaft's; its one state is the twist, an output, its rate der(twist) */
enum { SH_K, SH_C, SH_TWIST_START, SH_OMEGA_A, SH_OMEGA_B, SH_TAU, SH_TWIST, SH_E_SPRING, SH_DER_TWIST };
static const char* const SHAFT[] = {"k", "c", "twist_start", "omega_a", "omega_b", "tau", "twist", "E_spring",
                                    "der(twist)"};
/* the rod string's: its ports, then its design in crank_components.h's CD_ order (dynamics/well.py's
 * STRING_KEYS), then per taper (top first) TAPER_KEYS */
enum { RS_S, RS_V, RS_F, RS_U_PUMP, RS_F_PUMP, RS_W_POLISHED, RS_W_HYDRAULIC, RS_DESIGN };
static const char* const ROD_STRING[] = {"s", "v", "F", "u_pump", "F_pump", "W_polished", "W_hydraulic", "rho_fluid",
                                         "rho_steel", "plunger_diameter", "fluid_level", "p_tubing", "p_casing",
                                         "damping", "friction", "fillage", "g", "segment", "courant"};
#define RS_TAPERS (RS_DESIGN + CD_SIZE)
static const char* const TAPER_KEYS[] = {"length", "diameter", "E", "mass_per_length"};

static int find(const ModelData* d, const char* name)
{
    for (int vr = 0; vr < d->n_variables; vr++)
        if (strcmp(d->variables[vr].name, name) == 0) return vr;
    return -1;
}

static int bind_names(Component* c, const char* const* names, int n, int first, char* why, size_t why_size)
{
    for (int k = 0; k < n; k++)
        if ((c->slot[first + k] = find(c->d, names[k])) < 0) {
            snprintf(why, why_size, "it has no variable %s, which its model needs", names[k]);
            return -1;
        }
    return 0;
}

int model_bind(Component* c, char* why, size_t why_size)
{
    switch (c->d->kind) {
    case CM_MODEL_DRIVE:
    case CM_MODEL_DRIVE_SPEED: {
        int speed = c->d->kind == CM_MODEL_DRIVE_SPEED;
        if (bind_names(c, DRIVE, speed ? DR_J_DRIVE + 1 : DR_OMEGA_START, 0, why, why_size) != 0) return -1;
        /* the states' rates: variables a master reads for the drive's linear system (an FMU built
         * before they were declared has none, and the drive runs the same) */
        for (int j = 0; j < 2 + speed; j++) c->slot[DRIVE_RATE[j]] = find(c->d, DRIVE[DRIVE_RATE[j]]);
        return 0;
    }
    case CM_MODEL_CUSHION: return bind_names(c, CUSHION, CU_F + 1, 0, why, why_size);
    case CM_MODEL_SHAFT: return bind_names(c, SHAFT, SH_DER_TWIST + 1, 0, why, why_size);
    case CM_MODEL_ROD_STRING: {
        if (bind_names(c, ROD_STRING, RS_TAPERS, 0, why, why_size) != 0) return -1;
        char name[64];
        c->n_tapers = 0;
        for (;;) {               /* taper1_length, taper2_length, ... as long as they go on */
            snprintf(name, sizeof name, "taper%d_%s", c->n_tapers + 1, TAPER_KEYS[0]);
            if (find(c->d, name) < 0 || RS_TAPERS + 4 * (c->n_tapers + 1) > CM_MAX_VARIABLES) break;
            for (int k = 0; k < 4; k++) {
                snprintf(name, sizeof name, "taper%d_%s", c->n_tapers + 1, TAPER_KEYS[k]);
                const char* one[] = {name};
                if (bind_names(c, one, 1, RS_TAPERS + 4 * c->n_tapers + k, why, why_size) != 0) return -1;
            }
            c->n_tapers++;
        }
        if (c->n_tapers == 0) {
            snprintf(why, why_size, "it has no variable taper1_length: a rod string has at least one taper");
            return -1;
        }
        return 0;
    }
    default: snprintf(why, why_size, "its kind %d is no component's", c->d->kind); return -1;
    }
}

/* ------------------------------------------------------------------------------ the drive */

#define V(k) v[c->slot[k]]

static void drive_constants(const Component* c, const double* v, double* d)
{
    d[CC_R] = V(DR_R);
    d[CC_L] = V(DR_L);
    d[CC_K_T] = V(DR_K_T);
    d[CC_N_GEAR] = V(DR_N_GEAR);
    d[CC_KP] = V(DR_KP);
    d[CC_KI] = V(DR_KI);
}

/* the drive's state: the armature current i (A), the integral x of the speed error (rad), and in
 * speed causality the crank speed omega (rad/s), which it outputs (in torque causality an input) */
static void drive_outputs(const Component* c, double* v, const double* s, int speed)
{
    double d[CC_DRIVE_SIZE];
    drive_constants(c, v, d);
    if (speed) V(DR_OMEGA) = s[2];
    double u = cc_drive_voltage(d, s[1], V(DR_OMEGA), V(DR_OMEGA_SET));
    V(DR_TAU) = cc_drive_torque(d, s[0]);
    V(DR_I) = s[0];
    V(DR_U) = u;
    V(DR_P_EL) = u * s[0];
    V(DR_X) = s[1];
}

/* the inputs lines in time over the step where the host gave their derivatives (rates) */
static void drive_step(const Component* c, const double* v, const double* rates, double* s, double h, int speed)
{
    double d[CC_DRIVE_SIZE], out[3];
    drive_constants(c, v, d);
    const double* r = rates;
    if (speed) {
        cc_drive_step_with_rotor_ramp(d, s[0], s[1], s[2], V(DR_OMEGA_SET), V(DR_TAU_LOAD), r[c->slot[DR_OMEGA_SET]],
                                      r[c->slot[DR_TAU_LOAD]], V(DR_J_DRIVE), h, out);
        s[2] = out[2];
    } else {
        cc_drive_step_ramp(d, s[0], s[1], V(DR_OMEGA), V(DR_OMEGA_SET), r[c->slot[DR_OMEGA]], r[c->slot[DR_OMEGA_SET]],
                           h, out);
    }
    s[0] = out[0];
    s[1] = out[1];
}

/* ------------------------------------------------------------------------------ the elastic shaft */

/* the twist after the step, each side's speed a line where the host gave its derivative */
static void shaft_step(const Component* c, const double* v, const double* rates, double* s, double h)
{
    s[0] = cc_shaft_twist(s[0], V(SH_OMEGA_A), V(SH_OMEGA_B), rates[c->slot[SH_OMEGA_A]], rates[c->slot[SH_OMEGA_B]], h);
}

static void shaft_outputs(const Component* c, double* v, const double* s)
{
    V(SH_TAU) = cc_shaft_torque(V(SH_K), V(SH_C), s[0], V(SH_OMEGA_A), V(SH_OMEGA_B));
    V(SH_TWIST) = s[0];
    V(SH_E_SPRING) = cc_shaft_energy(V(SH_K), s[0]);
}

/* ------------------------------------------------------------------------------ the rod string */

/* The rod string (fmi/python/rodstring.py is the Python FMU of the same file): the state is the grid
 * (node masses and weights, segment stiffnesses), Gibbs' c, the pump, dt_max, whether the string
 * was hung at the first step, then the positions, velocities, the last positions, the scalars
 * and a scratch row. The string hangs at rest from the polished rod's position at the first step
 * (a master sets connected inputs after initialisation); each step moves the polished rod linearly
 * to s + v h. */
enum { ST_N, ST_C, ST_FO, ST_FRICTION, ST_FILLAGE, ST_DT_MAX, ST_HUNG, ST_HEAD };
/* the pieces of the state */
#define ST_NODES(s) ((int)(s)[ST_N])
#define ST_MASS(s) ((s) + ST_HEAD)
#define ST_WEIGHT(s) (ST_MASS(s) + ST_NODES(s))
#define ST_STIFFNESS(s) (ST_WEIGHT(s) + ST_NODES(s))
#define ST_U(s) (ST_STIFFNESS(s) + ST_NODES(s))
#define ST_V(s) (ST_U(s) + ST_NODES(s))
#define ST_LAST(s) (ST_V(s) + ST_NODES(s))
#define ST_X(s) (ST_LAST(s) + ST_NODES(s))
#define ST_SCRATCH(s) (ST_X(s) + CS_SIZE)

/* the tapers (4 per taper, crank_components.h's order) and the design (CD_ order) from the values */
static void string_values(const Component* c, const double* v, double* tapers, double* design)
{
    for (int i = 0; i < 4 * c->n_tapers; i++) tapers[i] = V(RS_TAPERS + i);
    for (int k = 0; k < CD_SIZE; k++) design[k] = V(RS_DESIGN + k);
}

static int string_state_size(const Component* c, const double* v, char* why, int why_size)
{
    double tapers[CM_MAX_VARIABLES], design[CD_SIZE];
    string_values(c, v, tapers, design);
    int n = cc_string_nodes(c->n_tapers, tapers, design, why, why_size);
    return n ? ST_HEAD + 7 * n + CS_SIZE : 0;
}

static void string_start(const Component* c, const double* v, double t, double* s)
{
    double tapers[CM_MAX_VARIABLES], design[CD_SIZE], out[4];
    char why[8];
    string_values(c, v, tapers, design);
    int n = cc_string_nodes(c->n_tapers, tapers, design, why, sizeof why);
    s[ST_N] = n;
    cc_string_grid(c->n_tapers, tapers, design, ST_MASS(s), ST_WEIGHT(s), ST_STIFFNESS(s), out);
    s[ST_C] = out[0];
    s[ST_FO] = out[1];
    s[ST_FRICTION] = design[CD_FRICTION];
    s[ST_FILLAGE] = design[CD_FILLAGE];
    s[ST_DT_MAX] = out[2];
    s[ST_HUNG] = 0.0;
    double* x = ST_X(s);
    memset(x, 0, CS_SIZE * sizeof(double));
    x[CS_U_TOP] = x[CS_U_BOTTOM] = NAN;          /* no stroke seen yet */
    cc_string_hang(n, ST_WEIGHT(s), ST_STIFFNESS(s), t, V(RS_S), ST_U(s), ST_V(s), x);
    memcpy(ST_LAST(s), ST_U(s), (size_t)n * sizeof(double));
}

/* the polished rod moves linearly over the step: to s + v h, or with s's derivative given, to
 * s + ds/dt h */
static void string_step(const Component* c, const double* v, const double* rates, double* s, double h)
{
    int n = ST_NODES(s);
    double* x = ST_X(s);
    if (!(h > 0.0)) return;
    if (s[ST_HUNG] == 0.0) {
        cc_string_hang(n, ST_WEIGHT(s), ST_STIFFNESS(s), x[CS_T], V(RS_S), ST_U(s), ST_V(s), x);
        s[ST_HUNG] = 1.0;
    }
    double pump[3] = {s[ST_FO], s[ST_FRICTION], s[ST_FILLAGE]};
    cc_string_advance(n, ST_MASS(s), ST_WEIGHT(s), ST_STIFFNESS(s), s[ST_C], pump, ST_U(s), ST_V(s), ST_LAST(s), x,
                      V(RS_S) + (rates[c->slot[RS_S]] != 0.0 ? rates[c->slot[RS_S]] : V(RS_V)) * h, h, s[ST_DT_MAX],
                      ST_SCRATCH(s));
}

static void string_outputs(const Component* c, double* v, const double* s)
{
    int n = ST_NODES(s);
    const double *u = ST_U(s), *k = ST_STIFFNESS(s), *x = ST_X(s);
    V(RS_F) = k[0] * (u[1] - u[0]) + ST_WEIGHT(s)[0];
    V(RS_U_PUMP) = u[n - 1];
    V(RS_F_PUMP) = k[n - 2] * (u[n - 1] - u[n - 2]);
    V(RS_W_POLISHED) = x[CS_WORK];
    V(RS_W_HYDRAULIC) = x[CS_HYDRAULIC];
}

/* ------------------------------------------------------------------------------ by kind */

int model_state_size(const Component* c, const double* v, char* why, int why_size)
{
    switch (c->d->kind) {
    case CM_MODEL_DRIVE: return 2;
    case CM_MODEL_DRIVE_SPEED: return 3;
    case CM_MODEL_CUSHION: return 1;            /* no state: the force is the law at the inputs as set */
    case CM_MODEL_SHAFT: return 1;
    default: return string_state_size(c, v, why, why_size);
    }
}

void model_start(const Component* c, const double* v, double t, double* s)
{
    switch (c->d->kind) {
    case CM_MODEL_DRIVE_SPEED: s[2] = V(DR_OMEGA_START); /* fall through */
    case CM_MODEL_DRIVE:
        s[0] = V(DR_I_START);
        s[1] = V(DR_X_START);
        return;
    case CM_MODEL_CUSHION: return;
    case CM_MODEL_SHAFT: s[0] = V(SH_TWIST_START); return;
    default: string_start(c, v, t, s);
    }
}

void model_step(const Component* c, const double* v, const double* rates, double* s, double h)
{
    switch (c->d->kind) {
    case CM_MODEL_DRIVE:
    case CM_MODEL_DRIVE_SPEED: drive_step(c, v, rates, s, h, c->d->kind == CM_MODEL_DRIVE_SPEED); return;
    case CM_MODEL_CUSHION: return;
    case CM_MODEL_SHAFT: shaft_step(c, v, rates, s, h); return;
    default: string_step(c, v, rates, s, h);
    }
}

int model_smooth_states(const Component* c)
{
    switch (c->d->kind) {
    case CM_MODEL_DRIVE: return 2;             /* i, x */
    case CM_MODEL_DRIVE_SPEED: return 3;       /* i, x, omega */
    case CM_MODEL_CUSHION: return 0;
    case CM_MODEL_SHAFT: return 1;             /* twist */
    default: return -1;
    }
}

const char* model_state_output(const Component* c, int j)
{
    if (j < 0 || j >= model_smooth_states(c)) return NULL;
    return c->d->kind == CM_MODEL_SHAFT ? SHAFT[SH_TWIST] : DRIVE[DRIVE_STATE[j]];
}

/* the value reference of state j's rate variable, or -1 where the FMU declares none (a drive built
 * before the drives declared them) */
static int rate_variable(const Component* c, int j)
{
    return c->d->kind == CM_MODEL_SHAFT ? c->slot[SH_DER_TWIST] : c->slot[DRIVE_RATE[j]];
}

void model_rates(const Component* c, const double* v, const double* s, double* rates)
{
    double d[CC_DRIVE_SIZE];
    if (model_smooth_states(c) <= 0) return;
    if (c->d->kind == CM_MODEL_SHAFT) {
        rates[0] = V(SH_OMEGA_A) - V(SH_OMEGA_B);
        return;
    }
    drive_constants(c, v, d);
    int rotor = c->d->kind == CM_MODEL_DRIVE_SPEED;
    cc_drive_rates(d, s[0], s[1], rotor ? s[2] : V(DR_OMEGA), V(DR_OMEGA_SET), rotor ? V(DR_TAU_LOAD) : 0.0,
                   rotor ? V(DR_J_DRIVE) : 1.0, rotor, rates);
}

void model_outputs_rates(const Component* c, double* v, const double* s, double* rates)
{
    switch (c->d->kind) {
    case CM_MODEL_DRIVE:
    case CM_MODEL_DRIVE_SPEED: drive_outputs(c, v, s, c->d->kind == CM_MODEL_DRIVE_SPEED); break;
    case CM_MODEL_CUSHION:
        V(CU_F) = cc_cushion_force(V(CU_K), V(CU_C), V(CU_L_FREE), V(CU_S_SEAT), V(CU_S), V(CU_V));
        return;
    case CM_MODEL_SHAFT: shaft_outputs(c, v, s); break;
    default: string_outputs(c, v, s); return;
    }
    /* the states' rates, der(...) variables a master reads for the model's linear system */
    double own[3];
    if (!rates) rates = own;
    int n = model_smooth_states(c);
    model_rates(c, v, s, rates);
    for (int j = 0; j < n; j++)
        if (rate_variable(c, j) >= 0) v[rate_variable(c, j)] = rates[j];
}

void model_outputs(const Component* c, double* v, const double* s)
{
    model_outputs_rates(c, v, s, NULL);
}
