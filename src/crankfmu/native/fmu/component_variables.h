/* What a native component FMU's generated data (component_data.c, `crankfmu fmu ... --native`)
 * gives its model (component_model.c, behind the FMI 2.0 and 3.0 shells) and the component's
 * physics (component_models.c). */
#ifndef COMPONENT_VARIABLES_H
#define COMPONENT_VARIABLES_H

#include "component_config.h"      /* generated: MODEL_IDENTIFIER, MODEL_GUID, COMPONENT_*, N_VARIABLES, VR_* */

enum { KIND_OUTPUT, KIND_INPUT, KIND_TUNABLE, KIND_FIXED };

typedef struct {
    const char* name;
    int kind;
    double start;
    double min, max;               /* -inf, inf where unbounded */
    int min_inclusive, max_inclusive;
    const char* unit;
    const char* range_text;        /* as the data file states it: "(0, inf) Ohm" */
    const char* description;
} Variable;

extern const Variable VARIABLES[N_VARIABLES];

/* the component's model (component_models.c): the size of its state for the values set (a rod
 * string's grid follows its tapers), or 0 with the reason in why when the values make no model;
 * its state started at time t from the values; stepped by h s with the inputs held; and its
 * outputs written into the values */
int model_state_size(const double* values, char* why, int why_size);
void model_start(const double* values, double t, double* state);
void model_step(const double* values, double* state, double h);
void model_outputs(double* values, const double* state);

#endif
