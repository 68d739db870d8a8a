/* The components' physics, written once: the DC drive's exact step (dynamics/drive.py states the
 * same model, the independent reference its tests compare with), the die cushion's law, the elastic
 * shaft's law and step, and the rod string's steps with its valve pump (dynamics/rodstring.py: the
 * reference). The Python FMUs (Drive.fmu, DriveSpeed.fmu, DieCushion.fmu, ElasticShaft.fmu,
 * RodString.fmu) and the in-process well call these
 * through the kernel library; the native FMUs' runtime runs them (fmu/component_models.c). */
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
/* the same with omega and omega_set lines in time from the step's start (rates 1/s2; 0: held) */
CK_API void cc_drive_step_ramp(const double* drive, double i, double x, double omega, double omega_set, double rate,
                               double rate_set, double h, double* out);
/* (di/dt, dx/dt) and with the rotor domega/dt at the state and inputs (out[0:2], or [0:3]) */
CK_API void cc_drive_rates(const double* drive, double i, double x, double omega, double omega_set, double tau_load,
                           double J_drive, int rotor, double* out);
/* (i, x, omega) after h s of the speed-causal drive (it carries J_drive) with omega_set and
 * tau_load held: the matrix exponential of the linear system's augmented matrix (out[0:3]) */
CK_API void cc_drive_step_with_rotor(const double* drive, double i, double x, double omega, double omega_set,
                                     double tau_load, double J_drive, double h, double* out);
/* the same with omega_set and tau_load lines in time from the step's start (rates; 0: held) */
CK_API void cc_drive_step_with_rotor_ramp(const double* drive, double i, double x, double omega, double omega_set,
                                          double tau_load, double rate_set, double rate_load, double J_drive,
                                          double h, double* out);
/* exp(M) of an n x n matrix (row-major, n <= CC_EXPM_MAX) into out: scaling and squaring of its
 * Taylor series; cc_expm4 the 4 x 4 one */
enum { CC_EXPM_MAX = 6 };
CK_API void cc_expm(int n, const double* M, double* out);
CK_API void cc_expm4(const double* M, double* out);

/* the force on a press ram along its axis from a linear cushion (N): -(k (d - L_free) + c v),
 * d = s - s_seat; the tension law of a data file's spring_damper */
CK_API double cc_cushion_force(double k, double c, double L_free, double s_seat, double s, double v);

/* An elastic shaft between side a (a drive) and side b (a machine's crank): the torque it passes
 * from a to b, k twist + c (omega_a - omega_b) (N.m; it drives b and loads a), twist = phi_a - phi_b;
 * and the twist after h s with each side's speed a line from the step's start (rates rad/s2; 0:
 * held): exact, the twist is the integral of the speed difference; and the elastic energy the
 * spring stores, k twist^2 / 2 (J) */
CK_API double cc_shaft_torque(double k, double c, double twist, double omega_a, double omega_b);
CK_API double cc_shaft_twist(double twist, double omega_a, double omega_b, double rate_a, double rate_b, double h);
CK_API double cc_shaft_energy(double k, double twist);

/* The sucker-rod string (dynamics/rodstring.py states the same scheme: its reference): n nodes, 0
 * the polished rod, n - 1 the plunger; per node its mass (kg) and buoyant weight (N, downward), per
 * segment its stiffness E A / dx (N/m); Gibbs' damping c (1/s); the pump (Fo, friction, fillage).
 * The state: positions u at t (m, downward), velocities v half a step before, the positions a step
 * before (last_u), and the scalars x (CS_*). One explicit central-difference step of dt with the
 * polished rod moved to top_next, the pump's set-valued force solved exactly, the polished rod's
 * work, the damping loss and the pump's work (hydraulic, friction, stops) accumulated. scratch: n. */
enum { CS_T, CS_LOAD, CS_WORK, CS_DAMPING, CS_MOTION, CS_U_TOP, CS_U_BOTTOM, CS_HYDRAULIC, CS_FRICTION, CS_STOPS,
       CS_GAS, CS_SIZE };
CK_API void cc_string_step(int n, const double* mass, const double* weight, const double* stiffness, double c,
                           const double* pump, double* u, double* v, double* last_u, double* x, double top_next,
                           double dt, double* scratch);
/* a communication step of h s: as many equal steps as keep each at or below dt_max, the polished
 * rod moving linearly from where it is to top_end */
CK_API void cc_string_advance(int n, const double* mass, const double* weight, const double* stiffness, double c,
                              const double* pump, double* u, double* v, double* last_u, double* x, double top_end,
                              double h, double dt_max, double* scratch);

/* The string's design (dynamics/rodstring.py's StringDesign and grid, the reference): its tapers,
 * top first, each (length m, diameter m, E Pa, mass per length kg/m), and its values in
 * CS_DESIGN order. cc_string_nodes: the grid's node count, or 0 with the reason in why (a value
 * that makes a step unbounded, a negative fluid load), as the Python design's check says it. */
enum { CD_RHO_FLUID, CD_RHO_STEEL, CD_PLUNGER_DIAMETER, CD_FLUID_LEVEL, CD_P_TUBING, CD_P_CASING, CD_DAMPING,
       CD_FRICTION, CD_FILLAGE, CD_G, CD_SEGMENT, CD_COURANT, CD_SIZE };
#define CC_MAX_SEGMENTS 100000
#define CC_MIN_STEP 1e-6
CK_API int cc_string_nodes(int n_tapers, const double* tapers, const double* design, char* why, int why_size);
/* the grid: node masses and buoyant weights (n), segment stiffnesses (n - 1), and out = (Gibbs' c
 * 1/s, the fluid load Fo N, the largest stable step dt_max s, the buoyant weight Wrf N) */
CK_API void cc_string_grid(int n_tapers, const double* tapers, const double* design, double* mass, double* weight,
                           double* stiffness, double* out);
/* at rest at time t in static equilibrium hanging from the polished rod at top (the pump holding
 * nothing): u, v and the scalars x (the load; works and the pump's state from zero) */
CK_API void cc_string_hang(int n, const double* weight, const double* stiffness, double t, double top, double* u,
                           double* v, double* x);

#endif
