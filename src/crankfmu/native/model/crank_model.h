/* The native mechanism FMU's model behind the one model API (fmu_model.h), whatever FMI version
 * fronts it: its variables' values, the kernel's state and parameters, initialisation,
 * Co-Simulation steps (with or without a stop at each located switch), the Model Exchange calls,
 * and the FMU state as bytes. What a host is told is said here, once, with the calling function's
 * name.
 *
 * Every function that can refuse returns CM_OK or CM_ERROR; a refusal is logged through the
 * model's logger (the shell's: whatever loggingOn says) with the reason, and a model whose step
 * failed refuses further steps (CM_FAILED). */
#ifndef CRANK_MODEL_H
#define CRANK_MODEL_H

#include <stddef.h>

#include "crank_kernel.h"
#include "crank_mechanism.h"
#include "crank_variables.h"
#include "fmu_derivatives.h"
#include "fmu_states.h"
#include "model_status.h"

typedef struct {
    FmuStateMark mark;             /* first: what makes a copy an FMU state the shells know (fmu_states.h) */
    double S[CK_STATE_SIZE];       /* the kernel's whole state */
    double P[CK_PARAM_SIZE];       /* the kernel's parameters */
    double row[CK_OUT_SIZE];       /* the outputs at the current time */
    double values[CM_MAX_VARIABLES];   /* every variable's value (outputs are read from row); the
                                          model file's count used (crank_variables.h) */
    double time;
    double t_limit;                /* the stop time: steps may run to it, communication points come
                                      from the dense output (the trajectory does not depend on the
                                      communication step) */
    double event_ahead;            /* a switch the kernel located past the last communication point
                                      (its last step ends there), or -INFINITY: a step that stops at
                                      switches stops there */
    int phase;
    int pending;                   /* a tunable or the input changed: restart at the next step
                                      (Model Exchange: at the next event update) */
    int row_stale;                 /* Co-Simulation: an input was set since the row was computed:
                                      the next read computes it at the inputs set (cm_get) */
    double dydt[CK_N_Y];           /* Model Exchange: the derivatives at the current state */
    double input_rate[CM_MAX_INPUTS];   /* Co-Simulation: each input's first derivative (1/s), from
                                      fmi2SetRealInputDerivatives; 0 (held) once the input is set */
    int rate_given[CM_MAX_INPUTS];    /* whether the host gave it since it last set the input (speed
                                      causality: else omega1's slope is a backward difference) */
    unsigned char refused[CM_MAX_VARIABLES];   /* a value cm_set refused, not set anew since:
                                                  initialisation refuses while one is */
    double refused_value[CM_MAX_VARIABLES];
    int n_refused;                 /* how many: a step refuses while any is (one test on its path) */
    char failure[768];             /* why the model cannot go on, as it was said ("fmi2ExitInitialization
                                      Mode: ..."), which each later call that needs it repeats (the Python
                                      FMU's words, fmi/python/core.py); "" while nothing failed */
} Snapshot;

/* the tables the model builds (crank_mechanism.h's MM_TABLE_...) */
enum { CM_REDUCED, CM_QUANTITIES, CM_REACTIONS, CM_FRICTION, CM_TABLES };

typedef struct {
    const ModelData* d;            /* the scenario: the model file, read at instantiation */
    Snapshot now;
    CkTables tables;
    int model_exchange;
    CmLogger log;
    void* host;                    /* the shell's instance, given back to log */
    /* the C model at the values the tables were built for (built_for), and its tables: built
     * when initialisation ends (or an output is read in it), again when a reset or an FMU state
     * brings other values; they belong to the instance, not to its FMU states */
    mm_model mechanism;
    double* cubics[CM_TABLES];
    int intervals[CM_TABLES];
    double* built_for;             /* n_program_parameters + 1 (with the scratch below: cm_init) */
    double* scratch;               /* a read's quantities and reactions, a design's trial values */
    int have_tables;
    int tables_stale;              /* a parameter or the state changed since: compare before the next use */
    /* the joints' friction the kernel solves (tables.friction: NULL where no friction is active at
     * these values): its table interval-major (CkFriction's layout; cubics[CM_FRICTION] holds it
     * function-major, whose first functions, the rates, give each joint's power) */
    CkFriction friction;
    double* friction_interval_major;
    int friction_components[MM_MAX_FRICTIONS];
    double friction_c[MM_MAX_FRICTIONS];
} Model;

/* the mechanism of the model file d (read by fmu_model.c, which keeps it) at its start values;
 * log(host, ...) says what goes wrong. CM_ERROR, logged, where memory lacks. cm_free releases what
 * cm_init took; cm_release only the tables */
int cm_init(Model* m, const char* call, const ModelData* d, int model_exchange, CmLogger log, void* host);
void cm_free(Model* m);
void cm_release(Model* m);
/* an FMU state back (fmi2SetFMUstate, fmi3SetFMUState): its values may be another design's */
void cm_restore(Model* m, const Snapshot* state);
/* back to the start values (fmi2Reset, fmi3Reset) */
void cm_reset(Model* m);
/* a refusal: the message, formatted, to the logger as an error; returns CM_ERROR */
int cm_fail(const Model* m, const char* format, ...);
/* a refusal that stops the model (a design refused at initialisation, a failed step): as cm_fail,
 * and kept in now.failure for the calls that follow */
int cm_stop(Model* m, const char* format, ...);
/* why a call that needs a stepping model cannot go on: the failure kept, else the phase's reason */
const char* cm_cannot(const Model* m, const char* call, char* out, size_t n);

int cm_setup(Model* m, const char* call, double start_time, int stop_defined, double stop_time);
int cm_enter_initialization(Model* m, const char* call);
int cm_exit_initialization(Model* m, const char* call);
void cm_terminate(Model* m);

/* Co-Simulation: a step from t (the host's communication point) by h, its switches (the motor's
 * kink, a slider force's switch angle, the crank coming to rest or leaving it: each located by the
 * kernel, the mode changed there):
 * CM_SWITCHES_INSIDE   handled inside the step, which ends at t + h (FMI 2; FMI 3 without event
 *                      mode and early return);
 * CM_SWITCHES_STOP     the step ends at the first switch in (t, t + h] (*stopped 1, *t_end its
 *                      time), else at t + h (FMI 3's early return);
 * CM_SWITCHES_REPORT   handled inside the step, which ends at t + h; *stopped 1 if one was in it
 *                      (FMI 3's event mode without early return: the host's event update follows).
 * The kernel's steps are the same in the three, so are the values at t + h where no stop comes. */
enum { CM_SWITCHES_INSIDE, CM_SWITCHES_STOP, CM_SWITCHES_REPORT };
int cm_do_step(Model* m, const char* call, double t, double h, int switches, double* t_end, int* stopped);

/* values by value reference; an output in initialisation mode is what the values set give */
int cm_get(Model* m, const char* call, const unsigned* vr, size_t n, double* value);
int cm_set(Model* m, const char* call, const unsigned* vr, size_t n, const double* value);
/* Co-Simulation: inputs' first derivatives at the current communication point */
int cm_set_input_derivatives(Model* m, const char* call, const unsigned* vr, size_t n, const int* order,
                             const double* value);

/* For masters (crank_model_derivatives.c), after the end of initialisation: the model's equations
 * at the current point for fmu_derivatives.h, evaluating the unknowns (outputs and, unless for
 * the outputs' time derivatives along the next step (trajectory: Co-Simulation), the states'
 * derivatives); its knowns are the continuous states (the outputs that are states) and the
 * inputs. Returns the point to free once done, or NULL, refused with the reason */
void* cm_point(Model* m, const char* call, const unsigned* unknowns, size_t n_unknowns, int trajectory, FdModel* f);

/* Model Exchange (each refuses a Co-Simulation model, and one outside the phases it allows) */
int cm_me_ready(Model* m, const char* call, int initialization_too);
int cm_me_update(Model* m, const char* call, int* states_changed);
int cm_me_set_time(Model* m, const char* call, double time);
int cm_me_set_states(Model* m, const char* call, const double* x, size_t n);
int cm_me_get_states(Model* m, const char* call, double* x, size_t n);
int cm_me_get_derivatives(Model* m, const char* call, double* dx, size_t n);
int cm_me_get_indicators(Model* m, const char* call, double* z, size_t n);
int cm_me_get_nominals(Model* m, const char* call, double* nominals, size_t n);

/* the FMU state as bytes: a tag, then the snapshot (the same machine and build reads it back) */
size_t cm_serialized_size(void);
void cm_serialize(const Model* m, const Snapshot* s, unsigned char* bytes);
int cm_deserialize(const Model* m, const char* call, const unsigned char* bytes, size_t size, Snapshot* s);

#endif
