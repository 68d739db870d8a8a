/* The native FMUs' FMI 3.0 shell, Co-Simulation and Model Exchange: each call translated into the
 * one model API (fmu_model.h), as the FMI 2.0 shell does; every error is logged whatever loggingOn
 * says and the call returns fmi3Error.
 *
 * Value references: the model file's variables (crank_variables.h), then a mechanism's event
 * indicators (one per kernel event slot: fm_n_indicators) and last the independent variable time.
 * Co-Simulation: with eventModeUsed, a switch located in a step is the host's event (the step
 * ends there when earlyReturnAllowed, else at its end, eventHandlingNeeded set either way); with
 * earlyReturnAllowed only, the step returns at each switch (earlyReturn, lastSuccessfulTime);
 * with neither, every switch is handled inside the step, as in FMI 2.0 (the same values). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_model.h"
#include "fmi3Functions.h"
#include "fmi3_refusals.h"

#define N_VARIABLES(m) ((unsigned)(m)->d->n_variables)
#define VR_FIRST_INDICATOR(m) N_VARIABLES(m)
#define VR_TIME(m) (N_VARIABLES(m) + (unsigned)fm_n_indicators(m))

typedef struct {
    FmuModel model;
    char name[128];
    int event_mode_used, early_return_allowed;
    int in_event_mode;             /* Co-Simulation: between fmi3EnterEventMode and fmi3EnterStepMode */
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log_message;
} Instance;

static void log_to_host(void* host, int kind, const char* message)
{
    const Instance* in = (const Instance*)host;
    if (!in->log_message) return;
    if (kind == CM_LOG_OK && !in->model.logging_on) return;          /* warnings and errors: always */
    in->log_message(in->environment, kind == CM_LOG_ERROR ? fmi3Error : kind == CM_LOG_WARNING ? fmi3Warning : fmi3OK,
                    kind == CM_LOG_ERROR ? "logStatusError" : kind == CM_LOG_WARNING ? "logStatusWarning" : "logEvents",
                    message);
}

static fmi3Status status_of(int result) { return result == CM_OK ? fmi3OK : fmi3Error; }

#define MODEL(c) (&((Instance*)(c))->model)
/* a call on an instance forwarded to the model: fmi3Error for no instance */
#define FORWARD(instance, call) ((instance) ? status_of(call) : fmi3Error)

static Instance* instantiate(const char* call, fmi3String instanceName, fmi3String instantiationToken,
                             fmi3String resourcePath, fmi3Boolean loggingOn, fmi3InstanceEnvironment environment,
                             fmi3LogMessageCallback logMessage, int model_exchange, int event_mode_used)
{
    /* the instance first, so that every refusal below reaches the host through its logger */
    Instance* in = (Instance*)calloc(1, sizeof(Instance));
    if (!in) {
        if (logMessage) logMessage(environment, fmi3Error, "logStatusError", "out of memory for the instance");
        return NULL;
    }
    snprintf(in->name, sizeof in->name, "%s", instanceName ? instanceName : "?");
    in->environment = environment;
    in->log_message = logMessage;
    /* the model: the file in the FMU's resources, read and checked */
    if (fm_init(&in->model, call, resourcePath, 0, instantiationToken, model_exchange, log_to_host, in) == CM_OK) {
        if (!event_mode_used || !fm_event_mode_refusal(&in->model)) return fm_set_logging(&in->model, loggingOn), in;
        /* refused here, as the Reference FMUs do, not at the first event */
        fm_fail(&in->model, "%s: eventModeUsed = true, but this FMU has no event mode (hasEventMode = false in its "
                "modelDescription: %s): instantiate with eventModeUsed = false", call, fm_event_mode_refusal(&in->model));
        fm_free(&in->model);
    }
    free(in);
    return NULL;
}

const char* fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories, const fmi3String categories[])
{
    (void)nCategories, (void)categories;                  /* every category: one level */
    return FORWARD(instance, fm_set_logging(MODEL(instance), loggingOn));
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
    if (instance) fm_free(MODEL(instance));
    free(instance);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    (void)toleranceDefined;
    (void)tolerance;
    if (!instance) return fmi3Error;
    if (fm_setup(MODEL(instance), "fmi3EnterInitializationMode", startTime, stopTimeDefined, stopTime) != CM_OK)
        return fmi3Error;
    return status_of(fm_enter_initialization(MODEL(instance), "fmi3EnterInitializationMode"));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    Instance* in = (Instance*)instance;
    if (fm_exit_initialization(&in->model, "fmi3ExitInitializationMode") != CM_OK) return fmi3Error;
    /* Co-Simulation with event mode: the host's event update comes first, then fmi3EnterStepMode */
    in->in_event_mode = !fm_is_model_exchange(&in->model) && in->event_mode_used;
    return fmi3OK;
}

/* Co-Simulation with eventModeUsed: event mode entered (fmi3EnterEventMode) or left for step mode
 * (fmi3EnterStepMode); Model Exchange: its event mode entered */
static fmi3Status enter_mode(fmi3Instance instance, const char* call, int event_mode)
{
    if (!instance) return fmi3Error;
    Instance* in = (Instance*)instance;
    FmuModel* m = &in->model;
    if (fm_is_model_exchange(m))
        return status_of(event_mode ? fm_me(m, call, FM_ME_READY, NULL, 0) : fm_fail(m, "%s: Co-Simulation only", call));
    if (event_mode && !in->event_mode_used)
        return status_of(fm_fail(m, "%s: the host instantiated without eventModeUsed", call));
    if (fm_phase(m) != CM_STEPPING)
        return status_of(fm_fail(m, "%s: allowed once initialised, in step or event mode", call));
    in->in_event_mode = event_mode;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) { return enter_mode(instance, "fmi3EnterEventMode", 1); }
fmi3Status fmi3EnterStepMode(fmi3Instance instance) { return enter_mode(instance, "fmi3EnterStepMode", 0); }

fmi3Status fmi3Terminate(fmi3Instance instance) { return FORWARD(instance, fm_terminate(MODEL(instance))); }

fmi3Status fmi3Reset(fmi3Instance instance)
{
    if (instance) ((Instance*)instance)->in_event_mode = 0;
    return FORWARD(instance, fm_reset(MODEL(instance)));
}

/* ------------------------------------------------------------------------------ variables */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues)
{
    if (!instance) return fmi3Error;
    FmuModel* m = MODEL(instance);
    if (nValues != nValueReferences)
        return status_of(fm_fail(m, "fmi3GetFloat64: %u values for %u value references (every variable is a scalar)",
                                 (unsigned)nValues, (unsigned)nValueReferences));
    if (nValueReferences > 0 && (!valueReferences || !values)) return status_of(fm_fail(m, "%s", "fmi3GetFloat64: null arrays"));
    /* the model's variables only (a host reading its outputs): one read, which computes the
     * quantities and the joint reactions once for all of them */
    size_t model_only = 0;
    while (model_only < nValueReferences && valueReferences[model_only] < N_VARIABLES(m)) model_only++;
    if (model_only == nValueReferences)
        return status_of(fm_get(m, "fmi3GetFloat64", valueReferences, nValueReferences, values));
    for (size_t i = 0; i < nValueReferences; i++) {
        fmi3ValueReference vr = valueReferences[i];
        if (vr < N_VARIABLES(m)) {
            if (fm_get(m, "fmi3GetFloat64", &vr, 1, &values[i]) != CM_OK) return fmi3Error;
        } else if (vr == VR_TIME(m)) {
            values[i] = fm_time(m);
        } else if (vr < VR_TIME(m) && fm_is_model_exchange(m) && fm_phase(m) != CM_INSTANTIATED) {
            double z[CK_N_SLOTS];
            if (fm_me(m, "fmi3GetFloat64", FM_ME_GET_INDICATORS, z, fm_n_indicators(m)) != CM_OK) return fmi3Error;
            values[i] = z[vr - VR_FIRST_INDICATOR(m)];
        } else if (vr < VR_TIME(m)) {
            values[i] = 0.0;                 /* an event indicator before the model exists, or Co-Simulation */
        } else {
            return status_of(fm_fail(m, "fmi3GetFloat64: no variable has value reference %u", (unsigned)vr));
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues)
{
    if (!instance) return fmi3Error;
    FmuModel* m = MODEL(instance);
    if (nValues != nValueReferences)
        return status_of(fm_fail(m, "fmi3SetFloat64: %u values for %u value references (every variable is a scalar)",
                                 (unsigned)nValues, (unsigned)nValueReferences));
    for (size_t i = 0; i < nValueReferences; i++)
        if (valueReferences && valueReferences[i] >= N_VARIABLES(m))
            return status_of(fm_fail(m, "fmi3SetFloat64: value reference %u is %s", (unsigned)valueReferences[i],
                                     valueReferences[i] < VR_TIME(m) ? "an event indicator: it cannot be set"
                                     : valueReferences[i] == VR_TIME(m) ? "the time: it cannot be set"
                                                                     : "no variable's"));
    return status_of(fm_set(m, "fmi3SetFloat64", valueReferences, nValueReferences, values));
}

/* ------------------------------------------------------------------------------ for masters */

/* the sizes FMI 3.0 passes agree with the counts: every variable is a scalar */
static fmi3Status derivative_call(fmi3Instance instance, const char* call, const fmi3ValueReference unknowns[],
                                  size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                  const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                  size_t nSensitivity, int adjoint)
{
    if (!instance) return fmi3Error;
    size_t n_seed = adjoint ? nUnknowns : nKnowns, n_out = adjoint ? nKnowns : nUnknowns;
    if (nSeed != n_seed || nSensitivity != n_out)
        return status_of(fm_fail(MODEL(instance), "%s: %u seeds and %u sensitivities for %u unknowns and %u knowns "
                                 "(every variable is a scalar)", call, (unsigned)nSeed, (unsigned)nSensitivity,
                                 (unsigned)nUnknowns, (unsigned)nKnowns));
    return status_of(fm_directional(MODEL(instance), call, unknowns, nUnknowns, knowns, nKnowns, seed, sensitivity,
                                    adjoint));
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    return derivative_call(instance, "fmi3GetDirectionalDerivative", unknowns, nUnknowns, knowns, nKnowns, seed, nSeed,
                           sensitivity, nSensitivity, 0);
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    return derivative_call(instance, "fmi3GetAdjointDerivative", unknowns, nUnknowns, knowns, nKnowns, seed, nSeed,
                           sensitivity, nSensitivity, 1);
}

/* Co-Simulation (maxOutputDerivativeOrder 2): the outputs' derivatives along the next step */
fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    if (!instance) return fmi3Error;
    FmuModel* m = MODEL(instance);
    if (nValues != nValueReferences)
        return status_of(fm_fail(m, "fmi3GetOutputDerivatives: %u values for %u value references (every variable is a "
                                 "scalar)", (unsigned)nValues, (unsigned)nValueReferences));
    for (size_t i = 0; i < nValueReferences; i++)
        if (valueReferences && valueReferences[i] >= N_VARIABLES(m))
            return status_of(fm_fail(m, "fmi3GetOutputDerivatives: value reference %u is no output's",
                                     (unsigned)valueReferences[i]));
    return status_of(fm_output_derivatives(m, "fmi3GetOutputDerivatives", valueReferences, nValueReferences,
                                           (const int*)orders, values));
}

/* the other types, clocks and the calls this FMU does not provide: fmi3_refusals.c */
fmi3Status fmi3_refuse(fmi3Instance instance, const char* message)
{
    return instance ? status_of(fm_fail(MODEL(instance), "%s", message)) : fmi3Error;
}

/* ------------------------------------------------------------------------------ FMU state */

/* each a forward to the model, which checks that a state is one of this FMU's (fmu_states.h) */
FMU_STATE_CALLS(fmi3Status, fmi3Instance, fmi3FMUState, fmi3Byte, fmi3GetFMUState, fmi3SetFMUState, fmi3FreeFMUState,
                fmi3SerializedFMUStateSize, fmi3SerializeFMUState, fmi3DeserializeFMUState)

/* ------------------------------------------------------------------------------ Co-Simulation */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* eventHandlingNeeded,
                      fmi3Boolean* terminateSimulation, fmi3Boolean* earlyReturn, fmi3Float64* lastSuccessfulTime)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!instance) return fmi3Error;
    Instance* in = (Instance*)instance;
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        return status_of(fm_fail(&in->model, "%s", "fmi3DoStep: null arguments"));
    *eventHandlingNeeded = *terminateSimulation = *earlyReturn = fmi3False;
    *lastSuccessfulTime = fm_time(&in->model);
    if (in->in_event_mode) return status_of(fm_fail(&in->model, "%s", "fmi3DoStep in event mode: fmi3EnterStepMode first"));
    int switches = in->early_return_allowed ? CM_SWITCHES_STOP
                   : in->event_mode_used    ? CM_SWITCHES_REPORT
                                            : CM_SWITCHES_INSIDE;
    double t_end;
    int stopped;
    int result = fm_do_step(&in->model, "fmi3DoStep", currentCommunicationPoint, communicationStepSize, switches, &t_end,
                            &stopped);
    *lastSuccessfulTime = fm_time(&in->model);
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
        return status_of(fm_fail(&in->model, "%s", "fmi3UpdateDiscreteStates: null arguments"));
    int changed = 0;
    if (fm_is_model_exchange(&in->model)) {
        if (fm_me_update(&in->model, "fmi3UpdateDiscreteStates", &changed) != CM_OK) return fmi3Error;
    } else if (!in->in_event_mode) {
        return status_of(fm_fail(&in->model, "%s", "fmi3UpdateDiscreteStates: Co-Simulation in event mode only"));
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
    return instance ? status_of(fm_me(MODEL(instance), "fmi3EnterContinuousTimeMode", FM_ME_READY, NULL, 0)) : fmi3Error;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean* enterEventMode, fmi3Boolean* terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!instance) return fmi3Error;
    if (fm_me(MODEL(instance), "fmi3CompletedIntegratorStep", FM_ME_READY, NULL, 0) != CM_OK) return fmi3Error;
    if (!enterEventMode || !terminateSimulation)
        return status_of(fm_fail(MODEL(instance), "%s", "fmi3CompletedIntegratorStep: null arguments"));
    *enterEventMode = fmi3False;       /* every event is a state event, found by the indicators */
    *terminateSimulation = fmi3False;
    return fmi3OK;
}

/* the calls on the time and the state vector: one entry of the model (fm_me) */
static fmi3Status me(fmi3Instance instance, const char* call, int operation, double* x, size_t n)
{
    return instance ? status_of(fm_me(MODEL(instance), call, operation, x, n)) : fmi3Error;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    return me(instance, "fmi3SetTime", FM_ME_SET_TIME, &time, 1);
}

/* the calls on the state vector (fmu_model.h) */
FMU_STATE_VECTOR_CALLS(fmi3Status, fmi3Instance, fmi3Float64, fmi3SetContinuousStates, fmi3GetContinuousStates,
                       fmi3GetContinuousStateDerivatives, fmi3GetEventIndicators, fmi3GetNominalsOfContinuousStates)

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t* nEventIndicators)
{
    if (!instance || !nEventIndicators) return fmi3Error;
    *nEventIndicators = fm_is_model_exchange(MODEL(instance)) ? fm_n_indicators(MODEL(instance)) : 0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t* nContinuousStates)
{
    if (!instance || !nContinuousStates) return fmi3Error;
    *nContinuousStates = fm_n_states(MODEL(instance));
    return fmi3OK;
}
