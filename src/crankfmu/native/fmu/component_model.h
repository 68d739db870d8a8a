/* A native component FMU's model, whatever FMI version fronts it (the drive in either causality,
 * the die cushion, the rod string: component_models.c on crank_components.c): its variables'
 * values, initialisation, Co-Simulation steps, and the FMU state with the model's state array.
 * The FMI 2.0 shell (component_fmi2.c) and the FMI 3.0 shell (component_fmi3.c) translate their
 * calls into these; what a host is told is said here, once, with the calling function's name.
 *
 * The life cycle and the refusals are the Python FMU's (fmi/core.py): a value out of its range,
 * not finite, or a fixed parameter set after initialisation is refused with the parameter, the
 * value and its valid range; a step at a time that is not the FMU's own is refused; a model that
 * failed refuses further steps until it is reset. Outputs read in initialisation mode are those of
 * the values set there. Each refusal is logged through the logger and returns CO_ERROR. */
#ifndef COMPONENT_MODEL_H
#define COMPONENT_MODEL_H

#include <stddef.h>

#include "component_variables.h"
#include "fmu_states.h"

enum { CO_OK = 0, CO_ERROR = 1 };
enum { CO_INSTANTIATED, CO_INITIALIZATION, CO_STEPPING, CO_TERMINATED, CO_FAILED };

typedef struct {
    FmuStateMark mark;             /* first: what makes a copy an FMU state the shells know (fmu_states.h) */
    double values[N_VARIABLES];
    double time;
    int phase;
    int refused[N_VARIABLES];      /* a refused value: initialisation and steps fail until it is set well */
    int n_state;                   /* the model's state: 0 before initialisation */
    double* state;
} Snapshot;

/* a refusal's message to the host (the shell's logger: whatever loggingOn says) */
typedef void (*CoLogger)(void* host, const char* message);

typedef struct {
    Snapshot now;
    int stale;                     /* in initialisation mode: a value was set since the outputs were computed */
    CoLogger log;
    void* host;
} Component;

void co_init(Component* c, CoLogger log, void* host);
/* back to the start values, the model's state freed */
void co_reset(Component* c);
void co_free(Component* c);
int co_fail(const Component* c, const char* format, ...);

int co_setup(Component* c, const char* call, double start_time, int stop_defined, double stop_time);
int co_enter_initialization(Component* c, const char* call);
int co_exit_initialization(Component* c, const char* call);
void co_terminate(Component* c);
/* a step from t (the host's communication point) by h, the inputs held */
int co_do_step(Component* c, const char* call, double t, double h);
int co_get(Component* c, const char* call, const unsigned* vr, size_t n, double* value);
int co_set(Component* c, const char* call, const unsigned* vr, size_t n, const double* value);

/* FMU states: a copy of the snapshot and its model state (0 when out of memory), its release,
 * and its bytes (a tag, the snapshot, the model's state) */
int co_copy(Snapshot* to, const Snapshot* from);
void co_release(Snapshot* s);
size_t co_serialized_size(const Snapshot* s);
void co_serialize(const Snapshot* s, unsigned char* bytes);
/* the state the bytes hold, into *to (its model state allocated): CO_OK, or CO_ERROR logged */
int co_deserialize(const Component* c, const char* call, const unsigned char* bytes, size_t size, Snapshot* to);

#endif
