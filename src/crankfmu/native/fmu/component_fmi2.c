/* The native component FMUs' FMI 2.0 Co-Simulation shell: each call translated into the
 * component's model (component_model.h), which says what goes wrong; every error is logged
 * whatever loggingOn says and the call returns fmi2Error. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "component_model.h"
#include "fmi2Functions.h"
#include "fmi2_messages.h"

typedef struct {
    Component component;
    fmi2CallbackFunctions cb;
    char name[128];
    int logging_on;
} Instance;

static void log_to_host(void* host, const char* message)
{
    const Instance* in = (const Instance*)host;
    fmu_log(&in->cb, in->name, in->logging_on, fmi2Error, "logStatusError", "%s", message);
}

static fmi2Status status_of(int result) { return result == CO_OK ? fmi2OK : fmi2Error; }

#define COMPONENT(c) (&((Instance*)(c))->component)

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions* functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions) return NULL;
    Instance probe;
    memset(&probe, 0, sizeof probe);
    probe.cb = *functions;
    snprintf(probe.name, sizeof probe.name, "%s", instanceName ? instanceName : MODEL_IDENTIFIER);
    probe.component.log = log_to_host;
    probe.component.host = &probe;
    if (fmuType != fmi2CoSimulation) {
        co_fail(&probe.component, "%s.fmu is a Co-Simulation FMU: fmi2Instantiate with fmi2CoSimulation",
                MODEL_IDENTIFIER);
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, MODEL_GUID) != 0) {
        co_fail(&probe.component, "fmi2Instantiate: the GUID %s is not this FMU's (%s): the modelDescription.xml and "
                "the binary come from different builds", fmuGUID ? fmuGUID : "(null)", MODEL_GUID);
        return NULL;
    }
    Instance* in = (Instance*)calloc(1, sizeof(Instance));
    if (!in) {
        co_fail(&probe.component, "%s", "fmi2Instantiate: out of memory");
        return NULL;
    }
    in->cb = *functions;
    memcpy(in->name, probe.name, sizeof in->name);
    in->logging_on = loggingOn != 0;
    co_init(&in->component, log_to_host, in);
    return in;
}

void fmi2FreeInstance(fmi2Component c)
{
    if (!c) return;
    co_free(COMPONENT(c));
    free(c);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)nCategories;
    (void)categories;
    if (!c) return fmi2Error;
    ((Instance*)c)->logging_on = loggingOn != 0;
    return fmi2OK;
}

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    (void)toleranceDefined;
    (void)tolerance;
    if (!c) return fmi2Error;
    return status_of(co_setup(COMPONENT(c), "fmi2SetupExperiment", startTime, stopTimeDefined, stopTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    return c ? status_of(co_enter_initialization(COMPONENT(c), "fmi2EnterInitializationMode")) : fmi2Error;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    return c ? status_of(co_exit_initialization(COMPONENT(c), "fmi2ExitInitializationMode")) : fmi2Error;
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    if (!c) return fmi2Error;
    co_terminate(COMPONENT(c));
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    if (!c) return fmi2Error;
    co_reset(COMPONENT(c));
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!c) return fmi2Error;
    return status_of(co_do_step(COMPONENT(c), "fmi2DoStep", currentCommunicationPoint, communicationStepSize));
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    return c ? status_of(co_fail(COMPONENT(c), "%s", "fmi2DoStep never runs asynchronously: nothing to cancel"))
             : fmi2Error;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    return c ? status_of(co_get(COMPONENT(c), "fmi2GetReal", vr, nvr, value)) : fmi2Error;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    return c ? status_of(co_set(COMPONENT(c), "fmi2SetReal", vr, nvr, value)) : fmi2Error;
}

static fmi2Status no_variables(fmi2Component c, size_t nvr, const char* call)
{
    if (!c) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    return status_of(co_fail(COMPONENT(c), "%s: this FMU has Real variables only", call));
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    (void)vr, (void)value;
    return no_variables(c, nvr, "fmi2GetInteger");
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    (void)vr, (void)value;
    return no_variables(c, nvr, "fmi2SetInteger");
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    (void)vr, (void)value;
    return no_variables(c, nvr, "fmi2GetBoolean");
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    (void)vr, (void)value;
    return no_variables(c, nvr, "fmi2SetBoolean");
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    (void)vr, (void)value;
    return no_variables(c, nvr, "fmi2GetString");
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    (void)vr, (void)value;
    return no_variables(c, nvr, "fmi2SetString");
}

/* ---------------------------------------------------------------------------- FMU state */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* state)
{
    if (!c || !state) return fmi2Error;
    Snapshot* copy = *state ? (Snapshot*)*state : (Snapshot*)calloc(1, sizeof(Snapshot));
    if (!copy || !co_copy(copy, &COMPONENT(c)->now))
        return status_of(co_fail(COMPONENT(c), "%s", "fmi2GetFMUstate: out of memory"));
    *state = copy;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state)
{
    if (!c) return fmi2Error;
    Component* component = COMPONENT(c);
    if (!state) return status_of(co_fail(component, "%s", "fmi2SetFMUstate: no state"));
    if (!co_copy(&component->now, (const Snapshot*)state)) {
        co_reset(component);
        return status_of(co_fail(component, "%s", "fmi2SetFMUstate: out of memory (the instance is reset)"));
    }
    component->stale = component->now.phase == CO_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* state)
{
    if (!c) return fmi2Error;
    int slipped;                         /* the host passed the state, not its address (fmu_states.h) */
    void* s = fmu_state_to_free(state, &slipped);
    if (!s) return state && *state ? status_of(co_fail(COMPONENT(c), "%s", "fmi2FreeFMUstate: not a state of this "
                                                       "FMU (freed already?): nothing freed")) : fmi2OK;
    co_release((Snapshot*)s);
    fmu_state_unmark(s);
    free(s);
    if (!slipped) *state = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t* size)
{
    if (!c || !size) return fmi2Error;
    if (!state) return status_of(co_fail(COMPONENT(c), "%s", "fmi2SerializedFMUstateSize: no state"));
    *size = co_serialized_size((const Snapshot*)state);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size)
{
    if (!c) return fmi2Error;
    const Snapshot* s = (const Snapshot*)state;
    if (!s || !bytes || size < co_serialized_size(s))
        return status_of(co_fail(COMPONENT(c), "%s", "fmi2SerializeFMUstate: no state, or the buffer is smaller than "
                                                     "fmi2SerializedFMUstateSize"));
    co_serialize(s, (unsigned char*)bytes);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate* state)
{
    if (!c || !state) return fmi2Error;
    Snapshot* copy = *state ? (Snapshot*)*state : (Snapshot*)calloc(1, sizeof(Snapshot));
    if (!copy) return status_of(co_fail(COMPONENT(c), "%s", "fmi2DeSerializeFMUstate: out of memory"));
    if (co_deserialize(COMPONENT(c), "fmi2DeSerializeFMUstate", (const unsigned char*)bytes, size, copy) != CO_OK) {
        if (!*state) {
            co_release(copy);
            free(copy);
        }
        return fmi2Error;
    }
    *state = copy;
    return fmi2OK;
}

/* ---------------------------------------------------------------------------- not offered */
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    return c ? status_of(co_fail(COMPONENT(c), "%s", "fmi2GetDirectionalDerivative: not provided by this FMU"))
             : fmi2Error;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    return c ? status_of(co_fail(COMPONENT(c), "%s", "fmi2SetRealInputDerivatives: this FMU holds its inputs over a "
                                                     "step (canInterpolateInputs is false)"))
             : fmi2Error;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    return c ? status_of(co_fail(COMPONENT(c), "%s", "fmi2GetRealOutputDerivatives: not provided by this FMU"))
             : fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value)
{
    (void)s;
    if (!c || !value) return fmi2Error;
    *value = fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value)
{
    if (!c || !value) return fmi2Error;
    if (s != fmi2LastSuccessfulTime)
        return status_of(co_fail(COMPONENT(c), "%s", "fmi2GetRealStatus: only fmi2LastSuccessfulTime"));
    *value = COMPONENT(c)->now.time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer* value)
{
    (void)s, (void)value;
    return c ? status_of(co_fail(COMPONENT(c), "%s", "fmi2GetIntegerStatus: no integer status")) : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* value)
{
    if (!c || !value) return fmi2Error;
    if (s != fmi2Terminated) return status_of(co_fail(COMPONENT(c), "%s", "fmi2GetBooleanStatus: only fmi2Terminated"));
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String* value)
{
    (void)s, (void)value;
    return c ? status_of(co_fail(COMPONENT(c), "%s", "fmi2GetStringStatus: no string status")) : fmi2Error;
}
