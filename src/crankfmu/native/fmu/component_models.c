/* The native component FMUs' models: the drive (torque out, speed in), the drive in speed
 * causality (it carries the rotor: speed out, the mechanism's torque in) and the die cushion, each
 * on the components' physics (crank_components.c). component_config.h says which one this FMU is
 * and where each variable is (VR_<name>: the names of the data file, dynamics/drive.py and
 * dynamics/cushion.py require them). */
#include "component_fmi2.h"
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
void model_start(const double* v, double* s)
{
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
void model_start(const double* v, double* s)
{
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
void model_start(const double* v, double* s)
{
    (void)v;
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
#else
#error "component_config.h names no component (COMPONENT_DRIVE, COMPONENT_DRIVE_SPEED or COMPONENT_CUSHION)"
#endif
