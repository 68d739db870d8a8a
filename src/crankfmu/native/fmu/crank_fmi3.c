/* The native mechanism FMU's FMI 3.0 shell, Co-Simulation and Model Exchange: each call translated
 * into the model's (crank_model.h), as the FMI 2.0 shell does; every error is logged whatever
 * loggingOn says and the call returns fmi3Error.
 *
 * Value references: the model's variables (crank_variables.h), then, for Model Exchange, one
 * variable per event indicator (the kernel's event slots) and last the independent variable time.
 * Co-Simulation: with eventModeUsed, a switch located in a step is the host's event (the step
 * ends there when earlyReturnAllowed, else at its end, eventHandlingNeeded set either way); with
 * earlyReturnAllowed only, the step returns at each switch (earlyReturn, lastSuccessfulTime);
 * with neither, every switch is handled inside the step, as in FMI 2.0 (the same values). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crank_model.h"
#include "fmi3Functions.h"
#include "fmi3_refusals.h"

#define N_VARIABLES(m) ((unsigned)(m)->d->n_variables)
#define VR_FIRST_INDICATOR(m) N_VARIABLES(m)
#define VR_TIME(m) (N_VARIABLES(m) + CK_N_SLOTS)

typedef struct {
    Model model;
    char name[128];
    int logging_on;
    int event_mode_used, early_return_allowed;
    int in_event_mode;             /* Co-Simulation: between fmi3EnterEventMode and fmi3EnterStepMode */
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log_message;
} Instance;

static void log_to_host(void* host, int kind, const char* message)
{
    const Instance* in = (const Instance*)host;
    if (!in->log_message) return;
    if (kind == CM_LOG_OK && !in->logging_on) return;          /* warnings and errors: always */
    in->log_message(in->environment, kind == CM_LOG_ERROR ? fmi3Error : kind == CM_LOG_WARNING ? fmi3Warning : fmi3OK,
                    kind == CM_LOG_ERROR ? "logStatusError" : kind == CM_LOG_WARNING ? "logStatusWarning" : "logEvents",
                    message);
}

static fmi3Status status_of(int result) { return result == CM_OK ? fmi3OK : fmi3Error; }

#define MODEL(c) (&((Instance*)(c))->model)

static Instance* instantiate(const char* call, fmi3String instanceName, fmi3String instantiationToken,
                             fmi3String resourcePath, fmi3Boolean loggingOn, fmi3InstanceEnvironment environment,
                             fmi3LogMessageCallback logMessage, int model_exchange, int event_mode_used)
{
    Instance probe;
    memset(&probe, 0, sizeof probe);
    snprintf(probe.name, sizeof probe.name, "%s", instanceName ? instanceName : "?");
    probe.environment = environment;
    probe.log_message = logMessage;
    probe.model.log = log_to_host;
    probe.model.host = &probe;
    /* the model: the file in the FMU's resources (its scenario), read and checked */
    if (cm_init(&probe.model, call, resourcePath, 0, model_exchange, log_to_host, &probe) != CM_OK) return NULL;
    const ModelData* d = probe.model.d;
    Instance* in = NULL;
    if (d->causality_speed && model_exchange)
        cm_fail(&probe.model, "%s", "fmi3InstantiateModelExchange: this FMU is Co-Simulation only: in speed causality "
                "tau_drive needs omega1's derivative, which a Model Exchange host cannot pass");
    else if (d->causality_speed && event_mode_used)   /* refused here, as the Reference FMUs do, not at the first event */
        cm_fail(&probe.model, "%s", "fmi3InstantiateCoSimulation: eventModeUsed = true, but this FMU has no event mode "
                "(hasEventMode = false in its modelDescription: in speed causality the host's omega1 drives it, no switch "
                "is located): instantiate with eventModeUsed = false");
    else if (!instantiationToken || strcmp(instantiationToken, d->guid) != 0)
        cm_fail(&probe.model, "the instantiation token %s is not this FMU's (%s, in %s)",
                instantiationToken ? instantiationToken : "(null)", d->guid, CM_MODEL_FILE);
    else if (!(in = (Instance*)calloc(1, sizeof(Instance))))
        cm_fail(&probe.model, "%s", "out of memory for the instance");
    if (!in) {
        cm_free(&probe.model);
        return NULL;
    }
    memcpy(in->name, probe.name, sizeof in->name);
    in->environment = environment;
    in->log_message = logMessage;
    in->logging_on = loggingOn;
    in->model = probe.model;
    in->model.host = in;
    return in;
}

const char* fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    (void)nCategories;
    (void)categories;
    if (!instance) return fmi3Error;
    ((Instance*)instance)->logging_on = loggingOn;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage)
{
    (void)visible;
    return instantiate("fmi3InstantiateModelExchange", instanceName, instantiationToken, resourcePath, loggingOn,
                       instanceEnvironment, logMessage, 1, 0);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)visible;
    (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    Instance* in = instantiate("fmi3InstantiateCoSimulation", instanceName, instantiationToken, resourcePath, loggingOn,
                               instanceEnvironment, logMessage, 0, eventModeUsed);
    if (in) {
        in->event_mode_used = eventModeUsed;
        in->early_return_allowed = earlyReturnAllowed;
    }
    return in;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    if (instance) cm_free(&((Instance*)instance)->model);
    free(instance);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    (void)toleranceDefined;
    (void)tolerance;
    if (!instance) return fmi3Error;
    if (cm_setup(MODEL(instance), "fmi3EnterInitializationMode", startTime, stopTimeDefined, stopTime) != CM_OK)
        return fmi3Error;
    return status_of(cm_enter_initialization(MODEL(instance), "fmi3EnterInitializationMode"));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    Instance* in = (Instance*)instance;
    if (cm_exit_initialization(&in->model, "fmi3ExitInitializationMode") != CM_OK) return fmi3Error;
    /* Co-Simulation with event mode: the host's event update comes first, then fmi3EnterStepMode */
    in->in_event_mode = !in->model.model_exchange && in->event_mode_used;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    Instance* in = (Instance*)instance;
    if (in->model.model_exchange) return status_of(cm_me_ready(&in->model, "fmi3EnterEventMode", 0));
    if (!in->event_mode_used)
        return status_of(cm_fail(&in->model, "%s", "fmi3EnterEventMode: the host instantiated without eventModeUsed"));
    if (in->model.now.phase != CM_STEPPING)
        return status_of(cm_fail(&in->model, "%s", "fmi3EnterEventMode: allowed in step mode only"));
    in->in_event_mode = 1;
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    Instance* in = (Instance*)instance;
    if (in->model.model_exchange) return status_of(cm_fail(&in->model, "%s", "fmi3EnterStepMode: Co-Simulation only"));
    if (in->model.now.phase != CM_STEPPING)
        return status_of(cm_fail(&in->model, "%s", "fmi3EnterStepMode: the model is not initialised"));
    in->in_event_mode = 0;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    cm_terminate(MODEL(instance));
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    cm_reset(MODEL(instance));
    ((Instance*)instance)->in_event_mode = 0;
    return fmi3OK;
}

/* ------------------------------------------------------------------------------ variables */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues)
{
    if (!instance) return fmi3Error;
    Model* m = MODEL(instance);
    if (nValues != nValueReferences)
        return status_of(cm_fail(m, "fmi3GetFloat64: %u values for %u value references (every variable is a scalar)",
                                 (unsigned)nValues, (unsigned)nValueReferences));
    if (nValueReferences > 0 && (!valueReferences || !values)) return status_of(cm_fail(m, "%s", "fmi3GetFloat64: null arrays"));
    /* the model's variables only (a host reading its outputs): one read, which computes the
     * quantities and the joint reactions once for all of them */
    size_t model_only = 0;
    while (model_only < nValueReferences && valueReferences[model_only] < N_VARIABLES(m)) model_only++;
    if (model_only == nValueReferences)
        return status_of(cm_get(m, "fmi3GetFloat64", valueReferences, nValueReferences, values));
    for (size_t i = 0; i < nValueReferences; i++) {
        fmi3ValueReference vr = valueReferences[i];
        if (vr < N_VARIABLES(m)) {
            if (cm_get(m, "fmi3GetFloat64", &vr, 1, &values[i]) != CM_OK) return fmi3Error;
        } else if (vr == VR_TIME(m)) {
            values[i] = m->now.time;
        } else if (vr < VR_TIME(m) && m->model_exchange && m->now.phase != CM_INSTANTIATED) {
            double z[CK_N_SLOTS];
            if (cm_me_get_indicators(m, "fmi3GetFloat64", z, CK_N_SLOTS) != CM_OK) return fmi3Error;
            values[i] = z[vr - VR_FIRST_INDICATOR(m)];
        } else if (vr < VR_TIME(m)) {
            values[i] = 0.0;                 /* an event indicator before the model exists, or Co-Simulation */
        } else {
            return status_of(cm_fail(m, "fmi3GetFloat64: no variable has value reference %u", (unsigned)vr));
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues)
{
    if (!instance) return fmi3Error;
    Model* m = MODEL(instance);
    if (nValues != nValueReferences)
        return status_of(cm_fail(m, "fmi3SetFloat64: %u values for %u value references (every variable is a scalar)",
                                 (unsigned)nValues, (unsigned)nValueReferences));
    for (size_t i = 0; i < nValueReferences; i++)
        if (valueReferences && valueReferences[i] >= N_VARIABLES(m))
            return status_of(cm_fail(m, "fmi3SetFloat64: value reference %u is %s", (unsigned)valueReferences[i],
                                     valueReferences[i] < VR_TIME(m) ? "an event indicator: it cannot be set"
                                     : valueReferences[i] == VR_TIME(m) ? "the time: it cannot be set"
                                                                     : "no variable's"));
    return status_of(cm_set(m, "fmi3SetFloat64", valueReferences, nValueReferences, values));
}

/* the other types, clocks and the calls this FMU does not provide: fmi3_refusals.c */
fmi3Status fmi3_refuse(fmi3Instance instance, const char* message)
{
    return instance ? status_of(cm_fail(MODEL(instance), "%s", message)) : fmi3Error;
}

/* ------------------------------------------------------------------------------ FMU state */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState* FMUState)
{
    if (!instance || !FMUState) return fmi3Error;
    Snapshot* s = (Snapshot*)(*FMUState ? *FMUState : malloc(sizeof(Snapshot)));
    if (!s) return status_of(cm_fail(MODEL(instance), "%s", "fmi3GetFMUState: out of memory"));
    *s = MODEL(instance)->now;
    *FMUState = s;
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    if (!instance) return fmi3Error;
    if (!FMUState) return status_of(cm_fail(MODEL(instance), "%s", "fmi3SetFMUState: no state"));
    cm_restore(MODEL(instance), (const Snapshot*)FMUState);
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState* FMUState)
{
    if (!instance || !FMUState) return fmi3Error;
    int slipped;                         /* the host passed the state, not its address (fmu_states.h) */
    void* s = fmu_state_to_free(FMUState, &slipped);
    if (!s) return *FMUState ? status_of(cm_fail(MODEL(instance), "%s", "fmi3FreeFMUState: not a state of this "
                                                 "FMU (freed already?): nothing freed")) : fmi3OK;
    fmu_state_unmark(s);
    free(s);
    if (!slipped) *FMUState = NULL;
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t* size)
{
    (void)FMUState;
    if (!instance || !size) return fmi3Error;
    *size = cm_serialized_size();
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size)
{
    if (!instance || !FMUState || !serializedState) return fmi3Error;
    if (size < cm_serialized_size())
        return status_of(cm_fail(MODEL(instance), "%s", "fmi3SerializeFMUState: the buffer is too small"));
    cm_serialize(MODEL(instance), (const Snapshot*)FMUState, serializedState);
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState* FMUState)
{
    if (!instance || !serializedState || !FMUState) return fmi3Error;
    Snapshot read;
    if (cm_deserialize(MODEL(instance), "fmi3DeserializeFMUState", serializedState, size, &read) != CM_OK)
        return fmi3Error;
    Snapshot* s = (Snapshot*)(*FMUState ? *FMUState : malloc(sizeof(Snapshot)));
    if (!s) return status_of(cm_fail(MODEL(instance), "%s", "fmi3DeserializeFMUState: out of memory"));
    *s = read;
    *FMUState = s;
    return fmi3OK;
}

/* ------------------------------------------------------------------------------ Co-Simulation */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* eventHandlingNeeded,
                      fmi3Boolean* terminateSimulation, fmi3Boolean* earlyReturn, fmi3Float64* lastSuccessfulTime)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!instance) return fmi3Error;
    Instance* in = (Instance*)instance;
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        return status_of(cm_fail(&in->model, "%s", "fmi3DoStep: null arguments"));
    *eventHandlingNeeded = *terminateSimulation = *earlyReturn = fmi3False;
    *lastSuccessfulTime = in->model.now.time;
    if (in->in_event_mode) return status_of(cm_fail(&in->model, "%s", "fmi3DoStep in event mode: fmi3EnterStepMode first"));
    int switches = in->early_return_allowed ? CM_SWITCHES_STOP
                   : in->event_mode_used    ? CM_SWITCHES_REPORT
                                            : CM_SWITCHES_INSIDE;
    double t_end;
    int stopped;
    int result = cm_do_step(&in->model, "fmi3DoStep", currentCommunicationPoint, communicationStepSize, switches, &t_end,
                            &stopped);
    *lastSuccessfulTime = in->model.now.time;
    if (result != CM_OK) return fmi3Error;
    *earlyReturn = switches == CM_SWITCHES_STOP && stopped && t_end < currentCommunicationPoint + communicationStepSize;
    *eventHandlingNeeded = in->event_mode_used && stopped;
    return fmi3OK;
}

/* ------------------------------------------------------------------------------ events, both interfaces */

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean* discreteStatesNeedUpdate,
                                    fmi3Boolean* terminateSimulation, fmi3Boolean* nominalsOfContinuousStatesChanged,
                                    fmi3Boolean* valuesOfContinuousStatesChanged, fmi3Boolean* nextEventTimeDefined,
                                    fmi3Float64* nextEventTime)
{
    if (!instance) return fmi3Error;
    Instance* in = (Instance*)instance;
    if (!discreteStatesNeedUpdate || !terminateSimulation || !nominalsOfContinuousStatesChanged ||
        !valuesOfContinuousStatesChanged || !nextEventTimeDefined || !nextEventTime)
        return status_of(cm_fail(&in->model, "%s", "fmi3UpdateDiscreteStates: null arguments"));
    int changed = 0;
    if (in->model.model_exchange) {
        if (cm_me_update(&in->model, "fmi3UpdateDiscreteStates", &changed) != CM_OK) return fmi3Error;
    } else if (!in->in_event_mode) {
        return status_of(cm_fail(&in->model, "%s", "fmi3UpdateDiscreteStates: Co-Simulation in event mode only"));
    }
    /* Co-Simulation: the kernel changed the mode where it located the switch; inputs set in event
     * mode take effect from the next step, as any input does */
    *discreteStatesNeedUpdate = fmi3False;
    *terminateSimulation = fmi3False;
    *nominalsOfContinuousStatesChanged = fmi3False;
    *valuesOfContinuousStatesChanged = changed ? fmi3True : fmi3False;
    *nextEventTimeDefined = fmi3False;
    *nextEventTime = 0.0;
    return fmi3OK;
}

/* ------------------------------------------------------------------------------ Model Exchange */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    return instance ? status_of(cm_me_ready(MODEL(instance), "fmi3EnterContinuousTimeMode", 0)) : fmi3Error;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean* enterEventMode, fmi3Boolean* terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!instance) return fmi3Error;
    if (cm_me_ready(MODEL(instance), "fmi3CompletedIntegratorStep", 0) != CM_OK) return fmi3Error;
    if (!enterEventMode || !terminateSimulation)
        return status_of(cm_fail(MODEL(instance), "%s", "fmi3CompletedIntegratorStep: null arguments"));
    *enterEventMode = fmi3False;       /* every event is a state event, found by the indicators */
    *terminateSimulation = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    return instance ? status_of(cm_me_set_time(MODEL(instance), "fmi3SetTime", time)) : fmi3Error;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    return instance ? status_of(cm_me_set_states(MODEL(instance), "fmi3SetContinuousStates", continuousStates,
                                                 nContinuousStates))
                    : fmi3Error;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates)
{
    return instance ? status_of(cm_me_get_derivatives(MODEL(instance), "fmi3GetContinuousStateDerivatives", derivatives,
                                                      nContinuousStates))
                    : fmi3Error;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators)
{
    return instance ? status_of(cm_me_get_indicators(MODEL(instance), "fmi3GetEventIndicators", eventIndicators,
                                                     nEventIndicators))
                    : fmi3Error;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates)
{
    return instance ? status_of(cm_me_get_states(MODEL(instance), "fmi3GetContinuousStates", continuousStates,
                                                 nContinuousStates))
                    : fmi3Error;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates)
{
    return instance ? status_of(cm_me_get_nominals(MODEL(instance), "fmi3GetNominalsOfContinuousStates", nominals,
                                                   nContinuousStates))
                    : fmi3Error;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t* nEventIndicators)
{
    if (!instance || !nEventIndicators) return fmi3Error;
    *nEventIndicators = MODEL(instance)->model_exchange ? CK_N_SLOTS : 0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t* nContinuousStates)
{
    if (!instance || !nContinuousStates) return fmi3Error;
    *nContinuousStates = MODEL(instance)->model_exchange ? N_STATES : 0;
    return fmi3OK;
}
