/* A native component FMU's model (the drive in either causality, the die cushion, the rod string:
 * component_models.c on crank_components.c) behind the one model API (fmu_model.h): its variables'
 * values, initialisation, Co-Simulation steps, and the FMU state with the model's state array.
 * What a component adds is data: its model file (crank_variables.h) gives its kind and variables.
 *
 * The life cycle and the refusals are the Python FMU's (fmi/python/core.py): a value out of its range,
 * not finite, or a fixed parameter set after initialisation is refused with the parameter, the
 * value and its valid range; a step at a time that is not the FMU's own is refused; a model that
 * failed refuses further steps until it is reset. Outputs read in initialisation mode are those of
 * the values set there. Each refusal is logged through the logger and returns CM_ERROR. */
#ifndef COMPONENT_MODEL_H
#define COMPONENT_MODEL_H

#include <stddef.h>

#include "crank_variables.h"
#include "fmu_derivatives.h"
#include "fmu_states.h"
#include "model_status.h"

typedef struct {
    FmuStateMark mark;             /* first: what makes a copy an FMU state the shells know (fmu_states.h) */
    double values[CM_MAX_VARIABLES];
    double rate[CM_MAX_VARIABLES]; /* an input's first derivative (1/s) from the host, over the next step;
                                      0 (held) once the input is set again */
    double time;
    int phase;
    int refused[CM_MAX_VARIABLES]; /* a refused value: initialisation and steps fail until it is set well */
    int n_state;                   /* the model's state: 0 before initialisation */
    double* state;
} CoSnapshot;

typedef struct {
    const ModelData* d;            /* the model file: the kind and the variables */
    CoSnapshot now;
    int stale;                     /* in initialisation mode: a value was set since the outputs were computed */
    /* the value references of the variables the kind's model uses, by its names (component_models.c) */
    int slot[CM_MAX_VARIABLES];
    /* the inputs' value references in order: a step advances those given a derivative without
     * passing over every variable (a rod string has hundreds) */
    int input_vr[CM_MAX_VARIABLES];
    int n_inputs;
    int n_tapers;                  /* a rod string's */
    CmLogger log;
    void* host;
} Component;

/* the component of the model file d; CM_ERROR, logged, where d lacks a variable its model needs */
int co_init(Component* c, const char* call, const ModelData* d, CmLogger log, void* host);
/* back to the start values, the model's state freed */
void co_reset(Component* c);
void co_free(Component* c);

int co_setup(Component* c, const char* call, double start_time, int stop_defined, double stop_time);
int co_enter_initialization(Component* c, const char* call);
int co_exit_initialization(Component* c, const char* call);
/* a step from t (the host's communication point) by h, the inputs held */
int co_do_step(Component* c, const char* call, double t, double h);
int co_get(Component* c, const char* call, const unsigned* vr, size_t n, double* value);
int co_set(Component* c, const char* call, const unsigned* vr, size_t n, const double* value);
/* inputs' first derivatives at the current communication point (each input then a line over the
 * next step) */
int co_set_input_derivatives(Component* c, const char* call, const unsigned* vr, size_t n, const int* order,
                             const double* value);
/* for masters, after the end of initialisation (component_derivatives.c): the model's equations at
 * the current point for fmu_derivatives.h, evaluating the outputs unknowns; its knowns are the
 * inputs and the outputs that are states. Returns the point to free once done, or NULL, refused
 * with the reason (a rod string always: its grid's explicit steps are not smooth equations) */
void* co_point(Component* c, const char* call, const unsigned* unknowns, size_t n_unknowns, FdModel* f);
/* a refusal, logged; CM_ERROR */
int co_fail(const Component* c, const char* format, ...);

/* FMU states: a copy of the snapshot and its model state (0 when out of memory), its release,
 * and its bytes (a tag, the snapshot, the model's state) */
int co_copy(CoSnapshot* to, const CoSnapshot* from);
void co_release(CoSnapshot* s);
size_t co_serialized_size(const CoSnapshot* s);
void co_serialize(const CoSnapshot* s, unsigned char* bytes);
/* the state the bytes hold, into *to (its model state allocated): CM_OK, or CM_ERROR logged */
int co_deserialize(const Component* c, const char* call, const unsigned char* bytes, size_t size, CoSnapshot* to);

/* the kind's model (component_models.c): the variables it uses found by name (0, or -1 with the
 * missing name in why); the size of its state for the values set (a rod string's grid follows its
 * tapers), or 0 with the reason in why when the values make no model; its state started at time t
 * from the values; stepped by h s with the inputs held; and its outputs written into the values */
int model_bind(Component* c, char* why, size_t why_size);
int model_state_size(const Component* c, const double* values, char* why, int why_size);
void model_start(const Component* c, const double* values, double t, double* state);
void model_step(const Component* c, const double* values, const double* rates, double* state, double h);
void model_outputs(const Component* c, double* values, const double* state);
/* the same, and the smooth states' rates into rates (as model_rates; NULL: written to the der(...)
 * variables only), for callers that need both without computing the rates twice */
void model_outputs_rates(const Component* c, double* values, const double* state, double* rates);
/* the smooth models' equations: how many continuous states (the first of the state array; -1: a
 * rod string, none the derivatives can use), their names where an output is one (else NULL), and
 * their rates at the values and state */
int model_smooth_states(const Component* c);
const char* model_state_output(const Component* c, int j);
void model_rates(const Component* c, const double* values, const double* state, double* rates);

#endif
