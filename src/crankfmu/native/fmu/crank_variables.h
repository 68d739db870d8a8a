/* The native mechanism FMU's variables (crank_model.c, behind the FMI 2.0 and 3.0 shells): the
 * contract's variables at fixed value references, and the data `crankfmu fmu --native` generates
 * for one scenario (model_config.h: its identifier, GUID and counts; model_data.c: its compiled
 * program and the table of every variable). */
#ifndef CRANK_VARIABLES_H
#define CRANK_VARIABLES_H

#include "crank_kernel.h"
#include "model_config.h"

enum { KIND_OUTPUT, KIND_INPUT, KIND_TUNABLE, KIND_FIXED, KIND_QUANTITY, KIND_DERIVATIVE, KIND_REACTION };

typedef struct {
    const char* name;
    int kind;
    double start;
    int has_min, min_inclusive, has_max;
    double min, max;
    const char* range;     /* the valid range as the refusal message states it */
    const char* unit;
} Variable;

/* value references, in the order of native_build.NativeModel.data_c's table: the outputs first
 * (N_OUTPUTS, model_config.h), then the crank's input (VR_CRANK_INPUT), the tunables
 * (native_build.TUNABLE's order, or SPEED_TUNABLE's), the fixed parameters (N_FIXED), the
 * scenario's [[outputs]] and its ports' outputs (N_QUANTITIES), the derivatives of the Model
 * Exchange states (phi1, omega1, W_motor, W_load, W_ext: the kernel's y; none in speed causality),
 * the ports' inputs (N_PORTS) and the joint reactions (N_REACTIONS).
 *
 * Torque causality (CAUSALITY_SPEED 0): the input tau_ext, the motor line, Co-Simulation and
 * Model Exchange. Speed causality (1): the input omega1, the outputs tau_drive and W_drive in the
 * output row's M_motor and W_motor places (crank_kernel.h, ck_speed_*), Co-Simulation only:
 * tau_drive needs omega1's derivative, which a Model Exchange host has no call to pass. */
#if CAUSALITY_SPEED
enum { VR_CRANK_INPUT = N_OUTPUTS, VR_J_FLYWHEEL, VR_PHI1_START, VR_FIRST_FIXED };
#define N_DERIVATIVES 0
#else
enum {
    VR_CRANK_INPUT = N_OUTPUTS,
    VR_A, VR_B, VR_A_LOW, VR_B_LOW, VR_OMEGA_SWITCH, VR_J_FLYWHEEL, VR_PHI1_START, VR_OMEGA1_START, VR_RTOL,
    VR_FIRST_FIXED
};
#define N_DERIVATIVES N_STATES
#endif
#define N_STATES CK_N_Y
#define VR_FIRST_QUANTITY (VR_FIRST_FIXED + N_FIXED)
#define VR_FIRST_DERIVATIVE (VR_FIRST_QUANTITY + N_QUANTITIES)
#define VR_FIRST_PORT (VR_FIRST_DERIVATIVE + N_DERIVATIVES)
#define VR_FIRST_REACTION (VR_FIRST_PORT + N_PORTS)
#define N_VARIABLES (VR_FIRST_REACTION + N_REACTIONS)
/* the inputs: the crank's (0) and the ports' (1 + i) */
#define N_INPUTS (1 + N_PORTS)

/* each output's place in the kernel's output row (-1: E_kin, computed from J_red and omega1) */
extern const int OUTPUT_ROW[N_OUTPUTS];

extern const Variable VARIABLES[N_VARIABLES];

/* the scenario compiled for the C mechanism model (dynamics/program_scenario.py): its program, and
 * each of its parameters' value reference (-1: a parameter the FMU does not declare, at
 * PROGRAM_PARAMETER_VALUE), name, and the geometry parameters a refused assembly names */
#include "crank_mechanism.h"
extern const mm_program PROGRAM;
extern const int PROGRAM_PARAMETER_VR[N_PROGRAM_PARAMETERS];
extern const double PROGRAM_PARAMETER_VALUE[N_PROGRAM_PARAMETERS];
extern const char* const PROGRAM_PARAMETER_NAME[N_PROGRAM_PARAMETERS];
extern const char* const PROGRAM_CHECK_NAME[];
extern const int GEOMETRY_PARAMETERS[];
/* the program's parameters its tables depend on (the others, the motor line for one, do not) */
extern const int TABLE_PARAMETERS[];
extern const char* const UNKNOWN_NAMES[];

/* the [[outputs]]: quantity k is order QUANTITY_ORDER[k] (0 position, 1 velocity, 2 acceleration)
 * of coordinate QUANTITY_COORDINATE[k]; the C model's [[outputs]] table holds coordinate c's
 * q - winding phi1, q' and q'' (dynamics/tabulated.py, QuantityTable). The joint reactions: reaction
 * k is sum_j REACTION_TERMS weights (ck_reaction_weights) times the reactions table's cubics
 * k REACTION_TERMS + j (ReactionTable) */
extern const int QUANTITY_COORDINATE[];
extern const int QUANTITY_ORDER[];

#endif
