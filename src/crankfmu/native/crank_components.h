/* The components' physics, written once: the DC drive's exact step (dynamics/drive.py states the
 * same model, the independent reference its tests compare with) and the die cushion's law. The
 * Python FMUs (Drive.fmu, DriveSpeed.fmu, DieCushion.fmu) call these through the kernel library;
 * the native component FMUs compile them in (fmu/component_fmi2.c). */
#ifndef CRANK_COMPONENTS_H
#define CRANK_COMPONENTS_H

#ifndef CK_API
#define CK_API
#endif

/* the drive's constants, in dynamics/drive.py's DRIVE_CONSTANTS order */
enum { CC_R, CC_L, CC_K_T, CC_N_GEAR, CC_KP, CC_KI, CC_DRIVE_SIZE };

/* armature voltage u = Kp (omega_set - omega) + Ki x (V) */
CK_API double cc_drive_voltage(const double* drive, double x, double omega, double omega_set);
/* torque on the crank n_gear k_t i (N.m) */
CK_API double cc_drive_torque(const double* drive, double i);
/* (i, x) after h s with omega and omega_set held: the exact solution (out[0:2]) */
CK_API void cc_drive_step(const double* drive, double i, double x, double omega, double omega_set, double h,
                          double* out);
/* (i, x, omega) after h s of the speed-causal drive (it carries J_drive) with omega_set and
 * tau_load held: the matrix exponential of the linear system's augmented matrix (out[0:3]) */
CK_API void cc_drive_step_with_rotor(const double* drive, double i, double x, double omega, double omega_set,
                                     double tau_load, double J_drive, double h, double* out);
/* exp(M) of a 4 x 4 matrix (row-major) into out: scaling and squaring of its Taylor series */
CK_API void cc_expm4(const double* M, double* out);

/* the force on a press ram along its axis from a linear cushion (N): -(k (d - L_free) + c v),
 * d = s - s_seat; the tension law of a data file's spring_damper */
CK_API double cc_cushion_force(double k, double c, double L_free, double s_seat, double s, double v);

#endif
