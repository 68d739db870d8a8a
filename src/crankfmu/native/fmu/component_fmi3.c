/* The native component FMUs' FMI 3.0 Co-Simulation shell: each call translated into the
 * component's model (component_model.h), as the FMI 2.0 shell does; every error is logged
 * whatever loggingOn says and the call returns fmi3Error. A component has no events: no event
 * mode, no early return, no Model Exchange. Value references: the model's variables, then the
 * independent variable time. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "component_model.h"
#include "fmi3Functions.h"
#include "fmi3_refusals.h"

#define VR_TIME N_VARIABLES

typedef struct {
    Component component;
    char name[128];
    int logging_on;
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log_message;
} Instance;

static void log_to_host(void* host, const char* message)
{
    const Instance* in = (const Instance*)host;
    if (in->log_message) in->log_message(in->environment, fmi3Error, "logStatusError", message);
}

static fmi3Status status_of(int result) { return result == CO_OK ? fmi3OK : fmi3Error; }

#define COMPONENT(c) (&((Instance*)(c))->component)

fmi3Status fmi3_refuse(fmi3Instance instance, const char* message)
{
    return instance ? status_of(co_fail(COMPONENT(instance), "%s", message)) : fmi3Error;
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
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   MODEL_IDENTIFIER ".fmu is a Co-Simulation FMU: fmi3InstantiateCoSimulation");
    return NULL;
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
    (void)resourcePath, (void)visible, (void)requiredIntermediateVariables, (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    (void)earlyReturnAllowed;    /* allowed, never needed: every step ends where the host asks */
    Instance probe;
    memset(&probe, 0, sizeof probe);
    snprintf(probe.name, sizeof probe.name, "%s", instanceName ? instanceName : MODEL_IDENTIFIER);
    probe.environment = instanceEnvironment;
    probe.log_message = logMessage;
    probe.component.log = log_to_host;
    probe.component.host = &probe;
    if (!instantiationToken || strcmp(instantiationToken, MODEL_GUID) != 0) {
        co_fail(&probe.component, "fmi3InstantiateCoSimulation: the instantiation token %s is not this FMU's (%s): the "
                "modelDescription.xml and the binary come from different builds",
                instantiationToken ? instantiationToken : "(null)", MODEL_GUID);
        return NULL;
    }
    if (eventModeUsed) {      /* refused here, as the Reference FMUs do, not at the first fmi3UpdateDiscreteStates */
        co_fail(&probe.component, "%s", "fmi3InstantiateCoSimulation: eventModeUsed = true, but this FMU has no event "
                "mode (hasEventMode = false in its modelDescription: it has no events): instantiate with "
                "eventModeUsed = false");
        return NULL;
    }
    Instance* in = (Instance*)calloc(1, sizeof(Instance));
    if (!in) {
        co_fail(&probe.component, "%s", "fmi3InstantiateCoSimulation: out of memory");
        return NULL;
    }
    memcpy(in->name, probe.name, sizeof in->name);
    in->environment = instanceEnvironment;
    in->log_message = logMessage;
    in->logging_on = loggingOn;
    co_init(&in->component, log_to_host, in);
    return in;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    if (!instance) return;
    co_free(COMPONENT(instance));
    free(instance);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    (void)toleranceDefined, (void)tolerance;
    if (!instance) return fmi3Error;
    if (co_setup(COMPONENT(instance), "fmi3EnterInitializationMode", startTime, stopTimeDefined, stopTime) != CO_OK)
        return fmi3Error;
    return status_of(co_enter_initialization(COMPONENT(instance), "fmi3EnterInitializationMode"));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    return instance ? status_of(co_exit_initialization(COMPONENT(instance), "fmi3ExitInitializationMode")) : fmi3Error;
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    co_terminate(COMPONENT(instance));
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    co_reset(COMPONENT(instance));
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues)
{
    if (!instance) return fmi3Error;
    Component* c = COMPONENT(instance);
    if (nValues != nValueReferences)
        return status_of(co_fail(c, "fmi3GetFloat64: %u values for %u value references (every variable is a scalar)",
                                 (unsigned)nValues, (unsigned)nValueReferences));
    if (nValueReferences > 0 && (!valueReferences || !values)) return status_of(co_fail(c, "%s", "fmi3GetFloat64: null arrays"));
    size_t model_only = 0;                     /* the model's variables only: one read */
    while (model_only < nValueReferences && valueReferences[model_only] < N_VARIABLES) model_only++;
    if (model_only == nValueReferences) return status_of(co_get(c, "fmi3GetFloat64", valueReferences, nValueReferences, values));
    for (size_t i = 0; i < nValueReferences; i++) {
        if (valueReferences[i] == VR_TIME) {
            values[i] = c->now.time;
        } else if (co_get(c, "fmi3GetFloat64", &valueReferences[i], 1, &values[i]) != CO_OK) {
            return fmi3Error;
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues)
{
    if (!instance) return fmi3Error;
    Component* c = COMPONENT(instance);
    if (nValues != nValueReferences)
        return status_of(co_fail(c, "fmi3SetFloat64: %u values for %u value references (every variable is a scalar)",
                                 (unsigned)nValues, (unsigned)nValueReferences));
    for (size_t i = 0; i < nValueReferences; i++)
        if (valueReferences && valueReferences[i] == VR_TIME)
            return status_of(co_fail(c, "%s", "fmi3SetFloat64: time is the independent variable: it cannot be set"));
    return status_of(co_set(c, "fmi3SetFloat64", valueReferences, nValueReferences, values));
}

/* ------------------------------------------------------------------------------ FMU state */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState* FMUState)
{
    if (!instance || !FMUState) return fmi3Error;
    Snapshot* copy = *FMUState ? (Snapshot*)*FMUState : (Snapshot*)calloc(1, sizeof(Snapshot));
    if (!copy || !co_copy(copy, &COMPONENT(instance)->now))
        return status_of(co_fail(COMPONENT(instance), "%s", "fmi3GetFMUState: out of memory"));
    *FMUState = copy;
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    if (!instance) return fmi3Error;
    Component* c = COMPONENT(instance);
    if (!FMUState) return status_of(co_fail(c, "%s", "fmi3SetFMUState: no state"));
    if (!co_copy(&c->now, (const Snapshot*)FMUState)) {
        co_reset(c);
        return status_of(co_fail(c, "%s", "fmi3SetFMUState: out of memory (the instance is reset)"));
    }
    c->stale = c->now.phase == CO_INITIALIZATION;
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState* FMUState)
{
    if (!instance) return fmi3Error;
    int slipped;                         /* the host passed the state, not its address (fmu_states.h) */
    void* s = fmu_state_to_free(FMUState, &slipped);
    if (!s) return FMUState && *FMUState ? status_of(co_fail(COMPONENT(instance), "%s", "fmi3FreeFMUState: not a "
                                                             "state of this FMU (freed already?): nothing freed"))
                                         : fmi3OK;
    co_release((Snapshot*)s);
    fmu_state_unmark(s);
    free(s);
    if (!slipped) *FMUState = NULL;
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t* size)
{
    if (!instance || !size) return fmi3Error;
    if (!FMUState) return status_of(co_fail(COMPONENT(instance), "%s", "fmi3SerializedFMUStateSize: no state"));
    *size = co_serialized_size((const Snapshot*)FMUState);
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size)
{
    if (!instance) return fmi3Error;
    const Snapshot* s = (const Snapshot*)FMUState;
    if (!s || !serializedState || size < co_serialized_size(s))
        return status_of(co_fail(COMPONENT(instance), "%s", "fmi3SerializeFMUState: no state, or the buffer is smaller "
                                                            "than fmi3SerializedFMUStateSize"));
    co_serialize(s, serializedState);
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState* FMUState)
{
    if (!instance || !FMUState) return fmi3Error;
    Snapshot* copy = *FMUState ? (Snapshot*)*FMUState : (Snapshot*)calloc(1, sizeof(Snapshot));
    if (!copy) return status_of(co_fail(COMPONENT(instance), "%s", "fmi3DeserializeFMUState: out of memory"));
    if (co_deserialize(COMPONENT(instance), "fmi3DeserializeFMUState", serializedState, size, copy) != CO_OK) {
        if (!*FMUState) {
            co_release(copy);
            free(copy);
        }
        return fmi3Error;
    }
    *FMUState = copy;
    return fmi3OK;
}

/* ------------------------------------------------------------------------------ Co-Simulation */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* eventHandlingNeeded,
                      fmi3Boolean* terminateSimulation, fmi3Boolean* earlyReturn, fmi3Float64* lastSuccessfulTime)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!instance) return fmi3Error;
    Component* c = COMPONENT(instance);
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        return status_of(co_fail(c, "%s", "fmi3DoStep: null arguments"));
    *eventHandlingNeeded = *terminateSimulation = *earlyReturn = fmi3False;
    int result = co_do_step(c, "fmi3DoStep", currentCommunicationPoint, communicationStepSize);
    *lastSuccessfulTime = c->now.time;
    return status_of(result);
}

/* ------------------------------------------------------------------------------ no events, no Model Exchange */

#define REFUSED(call, args, why)                                                   \
    fmi3Status call args { return fmi3_refuse(instance, #call ": " why); }

REFUSED(fmi3EnterEventMode, (fmi3Instance instance), "this FMU has no events (hasEventMode is false)")
REFUSED(fmi3EnterStepMode, (fmi3Instance instance), "this FMU has no event mode to leave")
REFUSED(fmi3EnterContinuousTimeMode, (fmi3Instance instance), "Model Exchange only")
REFUSED(fmi3UpdateDiscreteStates,
        (fmi3Instance instance, fmi3Boolean* a, fmi3Boolean* b, fmi3Boolean* d, fmi3Boolean* e, fmi3Boolean* f,
         fmi3Float64* g),
        "this FMU has no events (hasEventMode is false)")
REFUSED(fmi3CompletedIntegratorStep, (fmi3Instance instance, fmi3Boolean a, fmi3Boolean* b, fmi3Boolean* d),
        "Model Exchange only")
REFUSED(fmi3SetTime, (fmi3Instance instance, fmi3Float64 time), "Model Exchange only")
REFUSED(fmi3SetContinuousStates, (fmi3Instance instance, const fmi3Float64 x[], size_t n), "Model Exchange only")
REFUSED(fmi3GetContinuousStateDerivatives, (fmi3Instance instance, fmi3Float64 x[], size_t n), "Model Exchange only")
REFUSED(fmi3GetEventIndicators, (fmi3Instance instance, fmi3Float64 x[], size_t n), "Model Exchange only")
REFUSED(fmi3GetContinuousStates, (fmi3Instance instance, fmi3Float64 x[], size_t n), "Model Exchange only")
REFUSED(fmi3GetNominalsOfContinuousStates, (fmi3Instance instance, fmi3Float64 x[], size_t n), "Model Exchange only")

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t* nEventIndicators)
{
    if (!instance || !nEventIndicators) return fmi3Error;
    *nEventIndicators = 0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t* nContinuousStates)
{
    if (!instance || !nContinuousStates) return fmi3Error;
    *nContinuousStates = 0;
    return fmi3OK;
}
