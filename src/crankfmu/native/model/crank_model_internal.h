/* What crank_model.c, crank_model_variables.c and crank_model_me.c share of the native mechanism
 * FMU's model (crank_model.h is what the FMI shells see). */
#ifndef CRANK_MODEL_INTERNAL_H
#define CRANK_MODEL_INTERNAL_H

#include "crank_model.h"
#include "crank_numbers.h"

/* the tables of the values the model holds: built (again) where they are missing or stale, or the
 * design refused with the CLI's message (CM_ERROR) */
int cm_ensure_tables(Model* m, const char* call);
/* the refusal of a design the C model cannot build (its mm status at these program values), in the
 * engine's words, into out (crank_model_refusals.c) */
void cm_design_refusal(const Model* m, const char* call, int status, const double* values, char* out, size_t size);
/* the kernel's parameters from the variables' values */
void cm_load_parameters(Model* m);
/* whether setting this variable sets the initial state (phi1_start, omega1_start) */
int cm_sets_initial_state(const Model* m, int vr);
/* the refusal of value x of variable vr, in the Python FMU's words (a parameter out of its range,
 * an input that is not finite): what cm_set says and initialisation repeats */
Refusal cm_refusal_text(const Model* m, int vr, double x);
/* every value refused and not set anew, each's refusal, "; " between them ("" for none) */
const char* cm_refusals(const Model* m, char* out, size_t n);
/* Model Exchange: the state and mode at the start; the derivatives and outputs there (1 when
 * finite) */
void cm_me_start(Model* m);
int cm_me_evaluate(Model* m);
/* Co-Simulation: the kernel's state and the output row at the start */
void cm_cs_start(Model* m);

/* the variables vr (computed ones from the model's output row, tables and state, the others its
 * values) into out */
void cm_read_values(const Model* m, const unsigned* vr, size_t n, double* out);

#endif
