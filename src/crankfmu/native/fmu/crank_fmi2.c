/* The native mechanism FMU's FMI 2.0 shell, Co-Simulation and Model Exchange: each call translated
 * into the model's (crank_model.h), which says what goes wrong; every error is logged whatever
 * loggingOn says and the call returns fmi2Error. Value references: crank_variables.h. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crank_model.h"
#include "fmi2Functions.h"
#include "fmi2_messages.h"

typedef struct {
    Model model;
    fmi2CallbackFunctions cb;
    fmi2String name;
    int logging_on;
} Instance;

static void log_to_host(void* host, int kind, const char* message)
{
    const Instance* in = (const Instance*)host;
    fmi2Status status = kind == CM_LOG_ERROR ? fmi2Error : kind == CM_LOG_WARNING ? fmi2Warning : fmi2OK;
    fmu_log(&in->cb, in->name, in->logging_on,
            status, kind == CM_LOG_ERROR ? "logStatusError" : kind == CM_LOG_WARNING ? "logStatusWarning" : "logAll",
            "%s", message);
}

static fmi2Status status_of(int result) { return result == CM_OK ? fmi2OK : fmi2Error; }

#define MODEL(c) (&((Instance*)(c))->model)

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions* functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)visible;
    if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
    Instance probe;
    memset(&probe, 0, sizeof probe);
    probe.cb = *functions;
    probe.name = instanceName ? instanceName : "?";
    probe.model.log = log_to_host;
    probe.model.host = &probe;
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        cm_fail(&probe.model, "%s", "fmi2Instantiate: fmuType is neither fmi2ModelExchange nor fmi2CoSimulation");
        return NULL;
    }
    /* the model: the file in the FMU's resources (its scenario), read and checked */
    if (cm_init(&probe.model, "fmi2Instantiate", fmuResourceLocation, 1, fmuType == fmi2ModelExchange, log_to_host,
                &probe) != CM_OK)
        return NULL;
    const ModelData* d = probe.model.d;
    const char* refused = NULL;
    if (d->causality_speed && fmuType == fmi2ModelExchange)
        refused = "fmi2Instantiate: this FMU is Co-Simulation only: in speed causality tau_drive needs omega1's "
                  "derivative, which a Model Exchange host cannot pass";
    else if (!fmuGUID || strcmp(fmuGUID, d->guid) != 0)
        cm_fail(&probe.model, "the GUID %s is not this FMU's (%s, in %s)", fmuGUID ? fmuGUID : "(null)", d->guid,
                CM_MODEL_FILE), refused = "";
    Instance* in = refused ? NULL : (Instance*)functions->allocateMemory(1, sizeof(Instance));
    size_t n = strlen(probe.name) + 1;
    char* name = in ? (char*)functions->allocateMemory(n, 1) : NULL;
    if (!name) {
        if (refused && *refused) cm_fail(&probe.model, "%s", refused);
        else if (!refused) cm_fail(&probe.model, "%s", "fmi2Instantiate: out of memory");
        if (in) functions->freeMemory(in);
        cm_free(&probe.model);
        return NULL;
    }
    memcpy(name, probe.name, n);
    in->cb = *functions;
    in->name = name;
    in->logging_on = loggingOn;
    in->model = probe.model;
    in->model.host = in;
    return in;
}

void fmi2FreeInstance(fmi2Component c)
{
    Instance* in = (Instance*)c;
    if (!in) return;
    fmi2CallbackFreeMemory release = in->cb.freeMemory;
    cm_free(&in->model);
    release((void*)in->name);
    release(in);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)nCategories;
    (void)categories;
    if (!c) return fmi2Error;
    ((Instance*)c)->logging_on = loggingOn;
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
    return status_of(cm_setup(MODEL(c), "fmi2SetupExperiment", startTime, stopTimeDefined, stopTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    if (!c) return fmi2Error;
    return status_of(cm_enter_initialization(MODEL(c), "fmi2EnterInitializationMode"));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    if (!c) return fmi2Error;
    return status_of(cm_exit_initialization(MODEL(c), "fmi2ExitInitializationMode"));
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    if (!c) return fmi2Error;
    cm_terminate(MODEL(c));
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    if (!c) return fmi2Error;
    cm_reset(MODEL(c));
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!c) return fmi2Error;
    double t_end;
    int stopped;
    return status_of(cm_do_step(MODEL(c), "fmi2DoStep", currentCommunicationPoint, communicationStepSize, 0, &t_end,
                                &stopped));
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    return c ? status_of(cm_fail(MODEL(c), "%s", "fmi2DoStep never runs asynchronously")) : fmi2Error;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    if (!c) return fmi2Error;
    return status_of(cm_get(MODEL(c), "fmi2GetReal", vr, nvr, value));
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    if (!c) return fmi2Error;
    return status_of(cm_set(MODEL(c), "fmi2SetReal", vr, nvr, value));
}

#define NO_SUCH(type, Type)                                                                                  \
    fmi2Status fmi2Get##Type(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, type value[])      \
    {                                                                                                        \
        (void)vr;                                                                                            \
        (void)value;                                                                                         \
        if (!c) return fmi2Error;                                                                            \
        return nvr == 0 ? fmi2OK : status_of(cm_fail(MODEL(c), "%s", "fmi2Get" #Type ": this FMU has no such variables")); \
    }                                                                                                        \
    fmi2Status fmi2Set##Type(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const type value[]) \
    {                                                                                                        \
        (void)vr;                                                                                            \
        (void)value;                                                                                         \
        if (!c) return fmi2Error;                                                                            \
        return nvr == 0 ? fmi2OK : status_of(cm_fail(MODEL(c), "%s", "fmi2Set" #Type ": this FMU has no such variables")); \
    }
NO_SUCH(fmi2Integer, Integer)
NO_SUCH(fmi2Boolean, Boolean)
NO_SUCH(fmi2String, String)

/* ------------------------------------------------------------------------------ FMU state */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* state)
{
    Instance* in = (Instance*)c;
    if (!in || !state) return fmi2Error;
    Snapshot* s = (Snapshot*)(*state ? *state : in->cb.allocateMemory(1, sizeof(Snapshot)));
    if (!s) return status_of(cm_fail(&in->model, "%s", "fmi2GetFMUstate: out of memory"));
    *s = in->model.now;
    *state = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state)
{
    if (!c) return fmi2Error;
    if (!state) return status_of(cm_fail(MODEL(c), "%s", "fmi2SetFMUstate: no state"));
    cm_restore(MODEL(c), (const Snapshot*)state);
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* state)
{
    Instance* in = (Instance*)c;
    if (!in || !state) return fmi2Error;
    int slipped;                         /* the host passed the state, not its address (fmu_states.h) */
    void* s = fmu_state_to_free(state, &slipped);
    if (!s) return *state ? status_of(cm_fail(&in->model, "%s", "fmi2FreeFMUstate: not a state of this FMU "
                                              "(freed already?): nothing freed")) : fmi2OK;
    fmu_state_unmark(s);
    in->cb.freeMemory(s);
    if (!slipped) *state = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t* size)
{
    (void)state;
    if (!c || !size) return fmi2Error;
    *size = cm_serialized_size();
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size)
{
    if (!c || !state || !bytes) return fmi2Error;
    if (size < cm_serialized_size()) return status_of(cm_fail(MODEL(c), "%s", "fmi2SerializeFMUstate: the buffer is too small"));
    cm_serialize(MODEL(c), (const Snapshot*)state, (unsigned char*)bytes);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate* state)
{
    Instance* in = (Instance*)c;
    if (!in || !bytes || !state) return fmi2Error;
    Snapshot read;
    if (cm_deserialize(&in->model, "fmi2DeSerializeFMUstate", (const unsigned char*)bytes, size, &read) != CM_OK)
        return fmi2Error;
    Snapshot* s = (Snapshot*)(*state ? *state : in->cb.allocateMemory(1, sizeof(Snapshot)));
    if (!s) return status_of(cm_fail(&in->model, "%s", "fmi2DeSerializeFMUstate: out of memory"));
    *s = read;
    *state = s;
    return fmi2OK;
}

/* ------------------------------------------------------------------------------ not provided */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    if (!c) return fmi2Error;
    return status_of(cm_fail(MODEL(c), "%s",
                             "fmi2GetDirectionalDerivative: not provided (providesDirectionalDerivative is false)"));
}

/* Co-Simulation (canInterpolateInputs): an input's first derivative at the current communication
 * point; the input is then linear in time over the next step (until it is set again) */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    if (!c) return fmi2Error;
    return status_of(cm_set_input_derivatives(MODEL(c), "fmi2SetRealInputDerivatives", vr, nvr, order, value));
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    return c ? status_of(cm_fail(MODEL(c), "%s", "fmi2GetRealOutputDerivatives: not provided")) : fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value)
{
    (void)s, (void)value;
    return c ? status_of(cm_fail(MODEL(c), "%s", "fmi2GetStatus: fmi2DoStep never returns fmi2Pending")) : fmi2Error;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value)
{
    if (!c) return fmi2Error;
    if (value && s == fmi2LastSuccessfulTime) {
        *value = MODEL(c)->now.time;
        return fmi2OK;
    }
    return status_of(cm_fail(MODEL(c), "%s", "fmi2GetRealStatus: only fmi2LastSuccessfulTime"));
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer* value)
{
    (void)s, (void)value;
    return c ? status_of(cm_fail(MODEL(c), "%s", "fmi2GetIntegerStatus: no such status")) : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* value)
{
    (void)s, (void)value;
    return c ? status_of(cm_fail(MODEL(c), "%s", "fmi2GetBooleanStatus: no such status")) : fmi2Error;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String* value)
{
    (void)s, (void)value;
    return c ? status_of(cm_fail(MODEL(c), "%s", "fmi2GetStringStatus: no such status")) : fmi2Error;
}

/* ------------------------------------------------------------------------------ Model Exchange */

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    return c ? status_of(cm_me_ready(MODEL(c), "fmi2EnterEventMode", 0)) : fmi2Error;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo* info)
{
    if (!c) return fmi2Error;
    if (!info) return status_of(cm_fail(MODEL(c), "%s", "fmi2NewDiscreteStates: no fmi2EventInfo"));
    int changed = 0;
    if (cm_me_update(MODEL(c), "fmi2NewDiscreteStates", &changed) != CM_OK) return fmi2Error;
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = changed ? fmi2True : fmi2False;
    info->nextEventTimeDefined = fmi2False;
    info->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    return c ? status_of(cm_me_ready(MODEL(c), "fmi2EnterContinuousTimeMode", 0)) : fmi2Error;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean* enterEventMode, fmi2Boolean* terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!c) return fmi2Error;
    if (cm_me_ready(MODEL(c), "fmi2CompletedIntegratorStep", 0) != CM_OK) return fmi2Error;
    if (!enterEventMode || !terminateSimulation)
        return status_of(cm_fail(MODEL(c), "%s", "fmi2CompletedIntegratorStep: null arguments"));
    *enterEventMode = fmi2False;       /* every event is a state event, found by the indicators */
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    return c ? status_of(cm_me_set_time(MODEL(c), "fmi2SetTime", time)) : fmi2Error;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    return c ? status_of(cm_me_set_states(MODEL(c), "fmi2SetContinuousStates", x, nx)) : fmi2Error;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    return c ? status_of(cm_me_get_states(MODEL(c), "fmi2GetContinuousStates", x, nx)) : fmi2Error;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    return c ? status_of(cm_me_get_derivatives(MODEL(c), "fmi2GetDerivatives", derivatives, nx)) : fmi2Error;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    return c ? status_of(cm_me_get_indicators(MODEL(c), "fmi2GetEventIndicators", eventIndicators, ni)) : fmi2Error;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    return c ? status_of(cm_me_get_nominals(MODEL(c), "fmi2GetNominalsOfContinuousStates", x_nominal, nx)) : fmi2Error;
}
