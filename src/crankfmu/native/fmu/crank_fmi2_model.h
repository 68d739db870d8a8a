/* What the FMI shell (crank_fmi2.c) knows of the model it wraps: the contract's variables at fixed
 * value references, and the data `crankfmu fmu --native` generates for one scenario
 * (model_config.h: its identifier, GUID, counts and rebuild command; model_data.c: its tables and
 * the table of every variable). */
#ifndef CRANK_FMI2_MODEL_H
#define CRANK_FMI2_MODEL_H

#include "model_config.h"

enum { KIND_OUTPUT, KIND_INPUT, KIND_TUNABLE, KIND_FIXED };

typedef struct {
    const char* name;
    int kind;
    double start;          /* a fixed parameter: the value the tables were built for */
    int has_min, min_inclusive, has_max;
    double min, max;
    const char* range;     /* the valid range as the refusal message states it */
    const char* unit;
} Variable;

/* the outputs first (N_OUTPUTS, from the contract: model_config.h), then the input, the tunables
 * (native_build.TUNABLE's order), then the fixed parameters */
enum {
    VR_TAU_EXT = N_OUTPUTS,
    VR_A, VR_B, VR_A_LOW, VR_B_LOW, VR_OMEGA_SWITCH, VR_J_FLYWHEEL, VR_PHI1_START, VR_OMEGA1_START, VR_RTOL,
    VR_FIRST_FIXED
};

/* each output's place in the kernel's output row (-1: E_kin, computed from J_red and omega1) */
extern const int OUTPUT_ROW[N_OUTPUTS];

extern const Variable VARIABLES[N_VARIABLES];
extern const double TABLE_COEFFICIENTS[];
extern const double TABLE_SWITCH_ANGLES[];
extern const double TABLE_FORCES[];

#endif
