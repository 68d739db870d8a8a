/* The native component FMUs' models: the drive (torque out, speed in), the drive in speed
 * causality (it carries the rotor: speed out, the mechanism's torque in), the die cushion and the
 * rod string, each on the components' physics (crank_components.c). component_config.h says which one this FMU is
 * and where each variable is (VR_<name>: the names of the data file, dynamics/drive.py and
 * dynamics/cushion.py require them). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "component_variables.h"
#include "crank_components.h"

#if defined(COMPONENT_DRIVE) || defined(COMPONENT_DRIVE_SPEED)
static void constants(const double* v, double* d)
{
    d[CC_R] = v[VR_R];
    d[CC_L] = v[VR_L];
    d[CC_K_T] = v[VR_k_t];
    d[CC_N_GEAR] = v[VR_n_gear];
    d[CC_KP] = v[VR_Kp];
    d[CC_KI] = v[VR_Ki];
}
#endif

#if defined(COMPONENT_DRIVE)
/* state: the armature current i (A), the integral x of the speed error (rad); omega an input */
int model_state_size(const double* v, char* why, int why_size)
{
    (void)v;
    (void)why;
    (void)why_size;
    return 2;
}

void model_start(const double* v, double t, double* s)
{
    (void)t;
    s[0] = v[VR_i_start];
    s[1] = v[VR_x_start];
}

void model_step(const double* v, double* s, double h)
{
    double d[CC_DRIVE_SIZE], out[2];
    constants(v, d);
    cc_drive_step(d, s[0], s[1], v[VR_omega], v[VR_omega_set], h, out);
    s[0] = out[0];
    s[1] = out[1];
}

void model_outputs(double* v, const double* s)
{
    double d[CC_DRIVE_SIZE];
    constants(v, d);
    double u = cc_drive_voltage(d, s[1], v[VR_omega], v[VR_omega_set]);
    v[VR_tau] = cc_drive_torque(d, s[0]);
    v[VR_i] = s[0];
    v[VR_u] = u;
    v[VR_P_el] = u * s[0];
}
#elif defined(COMPONENT_DRIVE_SPEED)
/* state: i, x and the crank speed omega (rad/s), which the drive outputs */
int model_state_size(const double* v, char* why, int why_size)
{
    (void)v;
    (void)why;
    (void)why_size;
    return 3;
}

void model_start(const double* v, double t, double* s)
{
    (void)t;
    s[0] = v[VR_i_start];
    s[1] = v[VR_x_start];
    s[2] = v[VR_omega_start];
}

void model_step(const double* v, double* s, double h)
{
    double d[CC_DRIVE_SIZE], out[3];
    constants(v, d);
    cc_drive_step_with_rotor(d, s[0], s[1], s[2], v[VR_omega_set], v[VR_tau_load], v[VR_J_drive], h, out);
    s[0] = out[0];
    s[1] = out[1];
    s[2] = out[2];
}

void model_outputs(double* v, const double* s)
{
    double d[CC_DRIVE_SIZE];
    constants(v, d);
    double u = cc_drive_voltage(d, s[1], s[2], v[VR_omega_set]);
    v[VR_omega] = s[2];
    v[VR_tau] = cc_drive_torque(d, s[0]);
    v[VR_i] = s[0];
    v[VR_u] = u;
    v[VR_P_el] = u * s[0];
}
#elif defined(COMPONENT_CUSHION)
/* no state: the force is the law at the inputs as the host set them */
int model_state_size(const double* v, char* why, int why_size)
{
    (void)v;
    (void)why;
    (void)why_size;
    return 1;
}

void model_start(const double* v, double t, double* s)
{
    (void)v;
    (void)t;
    (void)s;
}

void model_step(const double* v, double* s, double h)
{
    (void)v;
    (void)s;
    (void)h;
}

void model_outputs(double* v, const double* s)
{
    (void)s;
    v[VR_F] = cc_cushion_force(v[VR_k], v[VR_c], v[VR_L_free], v[VR_s_seat], v[VR_s], v[VR_v]);
}
#elif defined(COMPONENT_ROD_STRING)
/* The rod string (fmi/rodstring.py is the Python FMU of the same file): the state is the grid
 * (node masses and weights, segment stiffnesses), Gibbs' c, the pump, dt_max, whether the string
 * was hung at the first step, then the positions, velocities, the last positions, the scalars
 * and a scratch row. The string hangs at rest from the polished rod's position at the first step
 * (a master sets connected inputs after initialisation); each step moves the polished rod linearly
 * to s + v h. */
enum { RS_N, RS_C, RS_FO, RS_FRICTION, RS_FILLAGE, RS_DT_MAX, RS_HUNG, RS_HEAD };

static void values_of(const double* v, double* tapers, double* design)
{
    for (int i = 0; i < N_TAPERS; i++)
        for (int k = 0; k < 4; k++) tapers[4 * i + k] = v[TAPER_VR[i][k]];
    for (int k = 0; k < CD_SIZE; k++) design[k] = v[DESIGN_VR[k]];
}

int model_state_size(const double* v, char* why, int why_size)
{
    double tapers[4 * N_TAPERS], design[CD_SIZE];
    values_of(v, tapers, design);
    int n = cc_string_nodes(N_TAPERS, tapers, design, why, why_size);
    return n ? RS_HEAD + 7 * n + CS_SIZE : 0;
}

/* the pieces of the state */
#define RS_NODES(s) ((int)(s)[RS_N])
#define RS_MASS(s) ((s) + RS_HEAD)
#define RS_WEIGHT(s) (RS_MASS(s) + RS_NODES(s))
#define RS_STIFFNESS(s) (RS_WEIGHT(s) + RS_NODES(s))
#define RS_U(s) (RS_STIFFNESS(s) + RS_NODES(s))
#define RS_V(s) (RS_U(s) + RS_NODES(s))
#define RS_LAST(s) (RS_V(s) + RS_NODES(s))
#define RS_X(s) (RS_LAST(s) + RS_NODES(s))
#define RS_SCRATCH(s) (RS_X(s) + CS_SIZE)

void model_start(const double* v, double t, double* s)
{
    double tapers[4 * N_TAPERS], design[CD_SIZE], out[4];
    char why[8];
    values_of(v, tapers, design);
    int n = cc_string_nodes(N_TAPERS, tapers, design, why, sizeof why);
    s[RS_N] = n;
    cc_string_grid(N_TAPERS, tapers, design, RS_MASS(s), RS_WEIGHT(s), RS_STIFFNESS(s), out);
    s[RS_C] = out[0];
    s[RS_FO] = out[1];
    s[RS_FRICTION] = design[CD_FRICTION];
    s[RS_FILLAGE] = design[CD_FILLAGE];
    s[RS_DT_MAX] = out[2];
    s[RS_HUNG] = 0.0;
    double* x = RS_X(s);
    memset(x, 0, CS_SIZE * sizeof(double));
    x[CS_U_TOP] = x[CS_U_BOTTOM] = NAN;          /* no stroke seen yet */
    cc_string_hang(n, RS_WEIGHT(s), RS_STIFFNESS(s), t, v[VR_s], RS_U(s), RS_V(s), x);
    memcpy(RS_LAST(s), RS_U(s), (size_t)n * sizeof(double));
}

void model_step(const double* v, double* s, double h)
{
    int n = RS_NODES(s);
    double* x = RS_X(s);
    if (!(h > 0.0)) return;
    if (s[RS_HUNG] == 0.0) {
        cc_string_hang(n, RS_WEIGHT(s), RS_STIFFNESS(s), x[CS_T], v[VR_s], RS_U(s), RS_V(s), x);
        s[RS_HUNG] = 1.0;
    }
    double pump[3] = {s[RS_FO], s[RS_FRICTION], s[RS_FILLAGE]};
    cc_string_advance(n, RS_MASS(s), RS_WEIGHT(s), RS_STIFFNESS(s), s[RS_C], pump, RS_U(s), RS_V(s), RS_LAST(s), x,
                      v[VR_s] + v[VR_v] * h, h, s[RS_DT_MAX], RS_SCRATCH(s));
}

void model_outputs(double* v, const double* s)
{
    int n = RS_NODES(s);
    const double *u = RS_U(s), *k = RS_STIFFNESS(s), *x = RS_X(s);
    v[VR_F] = k[0] * (u[1] - u[0]) + RS_WEIGHT(s)[0];
    v[VR_u_pump] = u[n - 1];
    v[VR_F_pump] = k[n - 2] * (u[n - 1] - u[n - 2]);
    v[VR_W_polished] = x[CS_WORK];
    v[VR_W_hydraulic] = x[CS_HYDRAULIC];
}
#else
#error "component_config.h names no component (COMPONENT_DRIVE, COMPONENT_DRIVE_SPEED, COMPONENT_CUSHION or COMPONENT_ROD_STRING)"
#endif
