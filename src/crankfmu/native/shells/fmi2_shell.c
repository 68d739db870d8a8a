/* The native FMUs' FMI 2.0 shell, Co-Simulation and Model Exchange: each call translated into the
 * one model API (fmu_model.h), which says what goes wrong; every error is logged whatever
 * loggingOn says and the call returns fmi2Error. Value references: the model file's variables
 * (crank_variables.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_model.h"
#include "fmi2Functions.h"
#include "fmi2_messages.h"

typedef struct {
    FmuModel model;
    fmi2CallbackFunctions cb;
    char name[128];
} Instance;

static void log_to_host(void* host, int kind, const char* message)
{
    const Instance* in = (const Instance*)host;
    fmi2Status status = kind == CM_LOG_ERROR ? fmi2Error : kind == CM_LOG_WARNING ? fmi2Warning : fmi2OK;
    fmu_log(&in->cb, in->name, in->model.logging_on,
            status, kind == CM_LOG_ERROR ? "logStatusError" : kind == CM_LOG_WARNING ? "logStatusWarning" : "logAll",
            "%s", message);
}

static fmi2Status status_of(int result) { return result == CM_OK ? fmi2OK : fmi2Error; }

#define MODEL(c) (&((Instance*)(c))->model)
/* a call on an instance forwarded to the model: fmi2Error for no instance */
#define FORWARD(c, call) ((c) ? status_of(call) : fmi2Error)

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions* functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)visible;
    if (!functions || !functions->logger) return NULL;
    /* the instance first, so that every refusal below reaches the host through its logger */
    Instance* in = (Instance*)calloc(1, sizeof(Instance));
    if (!in) {
        functions->logger(functions->componentEnvironment, instanceName ? instanceName : "?", fmi2Error,
                          "logStatusError", "fmi2Instantiate: out of memory");
        return NULL;
    }
    in->cb = *functions;
    snprintf(in->name, sizeof in->name, "%s", instanceName ? instanceName : "?");
    int refused;
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        in->model.log = log_to_host;
        in->model.host = in;
        refused = fm_fail(&in->model, "%s", "fmi2Instantiate: fmuType is neither fmi2ModelExchange nor fmi2CoSimulation");
    } else {
        /* the model: the file in the FMU's resources, read and checked */
        refused = fm_init(&in->model, "fmi2Instantiate", fmuResourceLocation, 1, fmuGUID, fmuType == fmi2ModelExchange,
                          log_to_host, in);
    }
    if (refused == CM_OK) return fm_set_logging(&in->model, loggingOn), in;
    free(in);
    return NULL;
}

void fmi2FreeInstance(fmi2Component c)
{
    if (!c) return;
    fm_free(MODEL(c));
    free(c);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories, const fmi2String categories[])
{
    (void)nCategories, (void)categories;                  /* every category: one level */
    return FORWARD(c, fm_set_logging(MODEL(c), loggingOn));
}

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    (void)toleranceDefined;
    (void)tolerance;
    if (!c) return fmi2Error;
    return status_of(fm_setup(MODEL(c), "fmi2SetupExperiment", startTime, stopTimeDefined, stopTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    return FORWARD(c, fm_enter_initialization(MODEL(c), "fmi2EnterInitializationMode"));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    return FORWARD(c, fm_exit_initialization(MODEL(c), "fmi2ExitInitializationMode"));
}

fmi2Status fmi2Terminate(fmi2Component c) { return FORWARD(c, fm_terminate(MODEL(c))); }
fmi2Status fmi2Reset(fmi2Component c) { return FORWARD(c, fm_reset(MODEL(c))); }

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!c) return fmi2Error;
    double t_end;
    int stopped;
    return status_of(fm_do_step(MODEL(c), "fmi2DoStep", currentCommunicationPoint, communicationStepSize, 0, &t_end,
                                &stopped));
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    return c ? status_of(fm_fail(MODEL(c), "%s", "fmi2DoStep never runs asynchronously")) : fmi2Error;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    if (!c) return fmi2Error;
    return status_of(fm_get(MODEL(c), "fmi2GetReal", vr, nvr, value));
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    if (!c) return fmi2Error;
    return status_of(fm_set(MODEL(c), "fmi2SetReal", vr, nvr, value));
}

#define NO_SUCH(type, Type)                                                                                  \
    fmi2Status fmi2Get##Type(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, type value[])      \
    {                                                                                                        \
        (void)vr;                                                                                            \
        (void)value;                                                                                         \
        if (!c) return fmi2Error;                                                                            \
        return nvr == 0 ? fmi2OK : status_of(fm_fail(MODEL(c), "%s", "fmi2Get" #Type ": this FMU has no such variables")); \
    }                                                                                                        \
    fmi2Status fmi2Set##Type(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const type value[]) \
    {                                                                                                        \
        (void)vr;                                                                                            \
        (void)value;                                                                                         \
        if (!c) return fmi2Error;                                                                            \
        return nvr == 0 ? fmi2OK : status_of(fm_fail(MODEL(c), "%s", "fmi2Set" #Type ": this FMU has no such variables")); \
    }
NO_SUCH(fmi2Integer, Integer)
NO_SUCH(fmi2Boolean, Boolean)
NO_SUCH(fmi2String, String)

/* ------------------------------------------------------------------------------ FMU state */

/* each a forward to the model, which checks that a state is one of this FMU's (fmu_states.h) */
FMU_STATE_CALLS(fmi2Status, fmi2Component, fmi2FMUstate, fmi2Byte, fmi2GetFMUstate, fmi2SetFMUstate, fmi2FreeFMUstate,
                fmi2SerializedFMUstateSize, fmi2SerializeFMUstate, fmi2DeSerializeFMUstate)

/* ------------------------------------------------------------------------------ for masters */

/* ME and CS: the unknowns (outputs, the states' derivatives) with respect to the knowns (the
 * continuous states, the inputs) */
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    if (!c) return fmi2Error;
    return status_of(fm_directional(MODEL(c), "fmi2GetDirectionalDerivative", vUnknown_ref, nUnknown, vKnown_ref, nKnown,
                                    dvKnown, dvUnknown, 0));
}

/* Co-Simulation (canInterpolateInputs): an input's first derivative at the current communication
 * point; the input is then linear in time over the next step (until it is set again) */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    if (!c) return fmi2Error;
    return status_of(fm_set_input_derivatives(MODEL(c), "fmi2SetRealInputDerivatives", vr, nvr, order, value));
}

/* Co-Simulation (maxOutputDerivativeOrder 2): the outputs' derivatives along the next step */
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    if (!c) return fmi2Error;
    return status_of(fm_output_derivatives(MODEL(c), "fmi2GetRealOutputDerivatives", vr, nvr, order, value));
}

/* ------------------------------------------------------------------------------ not provided */

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value)
{
    (void)s, (void)value;
    return c ? status_of(fm_fail(MODEL(c), "%s", "fmi2GetStatus: fmi2DoStep never returns fmi2Pending")) : fmi2Error;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value)
{
    if (!c) return fmi2Error;
    if (value && s == fmi2LastSuccessfulTime) {
        *value = fm_time(MODEL(c));
        return fmi2OK;
    }
    return status_of(fm_fail(MODEL(c), "%s", "fmi2GetRealStatus: only fmi2LastSuccessfulTime"));
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer* value)
{
    (void)s, (void)value;
    return c ? status_of(fm_fail(MODEL(c), "%s", "fmi2GetIntegerStatus: no such status")) : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* value)
{
    (void)s, (void)value;
    return c ? status_of(fm_fail(MODEL(c), "%s", "fmi2GetBooleanStatus: no such status")) : fmi2Error;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String* value)
{
    (void)s, (void)value;
    return c ? status_of(fm_fail(MODEL(c), "%s", "fmi2GetStringStatus: no such status")) : fmi2Error;
}

/* ------------------------------------------------------------------------------ Model Exchange */

/* the calls on the time and the state vector, and the mode checks: one entry of the model (fm_me) */
static fmi2Status me(fmi2Component c, const char* call, int operation, double* x, size_t n)
{
    return c ? status_of(fm_me(MODEL(c), call, operation, x, n)) : fmi2Error;
}

fmi2Status fmi2EnterEventMode(fmi2Component c) { return me(c, "fmi2EnterEventMode", FM_ME_READY, NULL, 0); }

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo* info)
{
    if (!c) return fmi2Error;
    if (!info) return status_of(fm_fail(MODEL(c), "%s", "fmi2NewDiscreteStates: no fmi2EventInfo"));
    int changed = 0;
    int status = fm_me_update(MODEL(c), "fmi2NewDiscreteStates", &changed);
    /* no further update, no time event, nominals as they were: every flag false but one */
    memset(info, 0, sizeof *info);
    info->valuesOfContinuousStatesChanged = changed ? fmi2True : fmi2False;
    return status_of(status);
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    return me(c, "fmi2EnterContinuousTimeMode", FM_ME_READY, NULL, 0);
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean* enterEventMode, fmi2Boolean* terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (c && (!enterEventMode || !terminateSimulation))
        return status_of(fm_fail(MODEL(c), "%s", "fmi2CompletedIntegratorStep: null arguments"));
    if (c) *enterEventMode = *terminateSimulation = fmi2False;   /* every event a state event: the indicators find it */
    return me(c, "fmi2CompletedIntegratorStep", FM_ME_READY, NULL, 0);
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) { return me(c, "fmi2SetTime", FM_ME_SET_TIME, &time, 1); }

/* the calls on the state vector (fmu_model.h) */
FMU_STATE_VECTOR_CALLS(fmi2Status, fmi2Component, fmi2Real, fmi2SetContinuousStates, fmi2GetContinuousStates,
                       fmi2GetDerivatives, fmi2GetEventIndicators, fmi2GetNominalsOfContinuousStates)
