/* The one model API of crankfmu's native FMUs: what the FMI 2.0 shell (fmi2_shell.c) and the FMI
 * 3.0 shell (fmi3_shell.c) call, whatever the FMU is. The model file in the FMU's resources says
 * what it is (crank_variables.h): a mechanism (crank_model.h: Co-Simulation with its switches,
 * Model Exchange) or a component (component_model.h: Co-Simulation), and the calls go to that
 * model. What differs between FMUs is data: one runtime binary per FMI version and platform serves
 * them all.
 *
 * Every function that can refuse returns CM_OK or CM_ERROR; a refusal is logged through the
 * logger with the reason and the calling function's name. */
#ifndef FMU_MODEL_H
#define FMU_MODEL_H

#include <stddef.h>

#include "component_model.h"
#include "crank_model.h"

typedef struct {
    const ModelData* d;            /* the model file (kept here: the models borrow it) */
    CmLogger log;
    void* host;
    int logging_on;                /* the host's loggingOn (fmi2SetDebugLogging): the shells' loggers read it */
    Model mechanism;               /* d->kind CM_MODEL_MECHANISM */
    Component component;           /* the other kinds */
} FmuModel;

/* the model of the file in ``resources`` (md_load: a URI where is_uri), as a Model Exchange or a
 * Co-Simulation instance, at its start values. CM_ERROR, logged, where the file is refused, the
 * host's GUID (instantiation token) is not the file's, the interface is not the FMU's
 * (model_exchange) or memory lacks; fm_free releases what it took (and nothing where f->d is NULL). */
int fm_init(FmuModel* f, const char* call, const char* resources, int is_uri, const char* guid, int model_exchange,
            CmLogger log, void* host);
void fm_free(FmuModel* f);
int fm_fail(const FmuModel* f, const char* format, ...);
/* the host's loggingOn; CM_OK */
int fm_set_logging(FmuModel* f, int on);

/* what the FMU offers: events (NULL: a mechanism in torque causality, its switches; else why a
 * Co-Simulation host's event mode is refused at instantiation), and the event indicators and
 * continuous states a Model Exchange instance has (0 otherwise) */
const char* fm_event_mode_refusal(const FmuModel* f);
int fm_is_model_exchange(const FmuModel* f);
size_t fm_n_indicators(const FmuModel* f);
size_t fm_n_states(const FmuModel* f);
double fm_time(const FmuModel* f);
int fm_phase(const FmuModel* f);

int fm_reset(FmuModel* f);
int fm_setup(FmuModel* f, const char* call, double start_time, int stop_defined, double stop_time);
int fm_enter_initialization(FmuModel* f, const char* call);
int fm_exit_initialization(FmuModel* f, const char* call);
int fm_terminate(FmuModel* f);
/* a Co-Simulation step, its switches as crank_model.h's cm_do_step says (a component has none) */
int fm_do_step(FmuModel* f, const char* call, double t, double h, int switches, double* t_end, int* stopped);
int fm_get(FmuModel* f, const char* call, const unsigned* vr, size_t n, double* value);
int fm_set(FmuModel* f, const char* call, const unsigned* vr, size_t n, const double* value);
int fm_set_input_derivatives(FmuModel* f, const char* call, const unsigned* vr, size_t n, const int* order,
                             const double* value);

/* For masters, after the end of initialisation: the directional derivative (the Jacobian of the
 * unknowns, outputs or the states' derivatives, with respect to the knowns, continuous states or
 * inputs, times the seed) or with adjoint its transpose's product; the outputs' time derivatives
 * of order 1 to FM_MAX_OUTPUT_DERIVATIVE_ORDER along the next step (Co-Simulation; a rod string
 * refuses both: fmu_derivatives.h says how they are taken) */
enum { FM_MAX_OUTPUT_DERIVATIVE_ORDER = 2 };
int fm_directional(FmuModel* f, const char* call, const unsigned* unknowns, size_t n_unknowns, const unsigned* knowns,
                   size_t n_knowns, const double* seed, double* sensitivity, int adjoint);
int fm_output_derivatives(FmuModel* f, const char* call, const unsigned* vr, size_t n, const int* order, double* value);

/* Model Exchange (a Co-Simulation instance refuses each): one entry for the calls on the state
 * vector and the time, the operation named (x: n values, the time for FM_ME_SET_TIME), and the
 * event update */
enum { FM_ME_READY, FM_ME_SET_TIME, FM_ME_SET_STATES, FM_ME_GET_STATES, FM_ME_GET_DERIVATIVES, FM_ME_GET_INDICATORS,
       FM_ME_GET_NOMINALS };
int fm_me(FmuModel* f, const char* call, int operation, double* x, size_t n);
int fm_me_update(FmuModel* f, const char* call, int* states_changed);
/* The five calls on the state vector of an FMI shell, written once for both versions (which name
 * them apart): each a forward to fm_me (the array only read where the host sets it). The shell
 * defines FORWARD(instance, model call) and MODEL(instance). */
#define FMU_STATE_VECTOR_CALLS(Status, Instance, Real, SET, GET, DERIVATIVES, INDICATORS, NOMINALS)                \
    Status SET(Instance c, const Real x[], size_t n)                                                            \
    {                                                                                                           \
        return FORWARD(c, fm_me(MODEL(c), #SET, FM_ME_SET_STATES, (double*)x, n));                              \
    }                                                                                                           \
    Status GET(Instance c, Real x[], size_t n) { return FORWARD(c, fm_me(MODEL(c), #GET, FM_ME_GET_STATES, x, n)); } \
    Status DERIVATIVES(Instance c, Real x[], size_t n)                                                          \
    {                                                                                                           \
        return FORWARD(c, fm_me(MODEL(c), #DERIVATIVES, FM_ME_GET_DERIVATIVES, x, n));                          \
    }                                                                                                           \
    Status INDICATORS(Instance c, Real x[], size_t n)                                                           \
    {                                                                                                           \
        return FORWARD(c, fm_me(MODEL(c), #INDICATORS, FM_ME_GET_INDICATORS, x, n));                            \
    }                                                                                                           \
    Status NOMINALS(Instance c, Real x[], size_t n) { return FORWARD(c, fm_me(MODEL(c), #NOMINALS, FM_ME_GET_NOMINALS, x, n)); }

/* FMU states as a host hands them over (each state starts with the mark of fmu_states.h, so that
 * anything else a host passes is refused, not read): the current state into *state (reused where
 * it is a state of this FMU); set back; freed (*given as the standard says, or the state itself:
 * fmu_state_to_free); the size of its bytes, its bytes, and a state from bytes into *state */
int fm_state_save(FmuModel* f, const char* call, void** state);
int fm_state_restore(FmuModel* f, const char* call, const void* state);
int fm_state_release(FmuModel* f, const char* call, void** given);
int fm_state_size(FmuModel* f, const char* call, const void* state, size_t* size);
int fm_state_write(FmuModel* f, const char* call, const void* state, unsigned char* bytes, size_t size);
int fm_state_read(FmuModel* f, const char* call, const unsigned char* bytes, size_t size, void** state);

#endif
