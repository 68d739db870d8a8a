/* What an FMI 3.0 shell of crankfmu's native FMUs (fmi3_shell.c) refuses, written
 * once: the variable types other than Float64, binaries and clocks (the FMUs have none), and the
 * calls they do not provide (dependencies at run time, configuration mode, clocks' intervals and
 * shifts, scheduled execution). Each refusal is
 * the shell's own (fmi3_refuse: logged whatever loggingOn says, fmi3Error). */
#include <stdio.h>

#include "fmi3Functions.h"
#include "fmi3_refusals.h"

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn, (void)clockUpdate;
    (void)lockPreemption, (void)unlockPreemption;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateScheduledExecution: this FMU does not offer Scheduled Execution");
    return NULL;
}

#define NO_SUCH_GET(Type, type)                                                                                   \
    fmi3Status fmi3Get##Type(fmi3Instance instance, const fmi3ValueReference valueReferences[],                   \
                             size_t nValueReferences, type values[], size_t nValues)                              \
    {                                                                                                            \
        (void)valueReferences, (void)values, (void)nValues;                                                      \
        if (!instance) return fmi3Error;                                                                         \
        return nValueReferences == 0 ? fmi3OK                                                                    \
                                     : fmi3_refuse(instance, "fmi3Get" #Type ": this FMU has no such variables"); \
    }
#define NO_SUCH_SET(Type, type)                                                                                   \
    fmi3Status fmi3Set##Type(fmi3Instance instance, const fmi3ValueReference valueReferences[],                   \
                             size_t nValueReferences, const type values[], size_t nValues)                        \
    {                                                                                                            \
        (void)valueReferences, (void)values, (void)nValues;                                                      \
        if (!instance) return fmi3Error;                                                                         \
        return nValueReferences == 0 ? fmi3OK                                                                    \
                                     : fmi3_refuse(instance, "fmi3Set" #Type ": this FMU has no such variables"); \
    }
#define NO_SUCH(Type, type) NO_SUCH_GET(Type, type) NO_SUCH_SET(Type, type)
NO_SUCH(Float32, fmi3Float32)
NO_SUCH(Int8, fmi3Int8)
NO_SUCH(UInt8, fmi3UInt8)
NO_SUCH(Int16, fmi3Int16)
NO_SUCH(UInt16, fmi3UInt16)
NO_SUCH(Int32, fmi3Int32)
NO_SUCH(UInt32, fmi3UInt32)
NO_SUCH(Int64, fmi3Int64)
NO_SUCH(UInt64, fmi3UInt64)
NO_SUCH(Boolean, fmi3Boolean)
NO_SUCH(String, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    (void)valueReferences, (void)valueSizes, (void)values, (void)nValues;
    if (!instance) return fmi3Error;
    return nValueReferences == 0 ? fmi3OK : fmi3_refuse(instance, "fmi3GetBinary: this FMU has no such variables");
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    (void)valueReferences, (void)valueSizes, (void)values, (void)nValues;
    if (!instance) return fmi3Error;
    return nValueReferences == 0 ? fmi3OK : fmi3_refuse(instance, "fmi3SetBinary: this FMU has no such variables");
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[])
{
    (void)valueReferences, (void)values;
    if (!instance) return fmi3Error;
    return nValueReferences == 0 ? fmi3OK : fmi3_refuse(instance, "fmi3GetClock: this FMU has no clocks");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[])
{
    (void)valueReferences, (void)values;
    if (!instance) return fmi3Error;
    return nValueReferences == 0 ? fmi3OK : fmi3_refuse(instance, "fmi3SetClock: this FMU has no clocks");
}

/* ------------------------------------------------------------------------------ not provided */

static fmi3Status not_provided(fmi3Instance instance, const char* what)
{
    char message[160];
    snprintf(message, sizeof message, "%s: not provided by this FMU", what);
    return fmi3_refuse(instance, message);
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t* nDependencies)
{
    (void)valueReference, (void)nDependencies;
    return not_provided(instance, "fmi3GetNumberOfVariableDependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents;
    (void)dependencyKinds, (void)nDependencies;
    return not_provided(instance, "fmi3GetVariableDependencies");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) { return not_provided(instance, "fmi3EnterConfigurationMode"); }
fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) { return not_provided(instance, "fmi3ExitConfigurationMode"); }

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences, (void)nValueReferences, (void)intervals, (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalDecimal");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions, (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalFraction");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[])
{
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return not_provided(instance, "fmi3GetShiftDecimal");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, "fmi3GetShiftFraction");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[])
{
    (void)valueReferences, (void)nValueReferences, (void)intervals;
    return not_provided(instance, "fmi3SetIntervalDecimal");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, "fmi3SetIntervalFraction");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[])
{
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return not_provided(instance, "fmi3SetShiftDecimal");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, "fmi3SetShiftFraction");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) { return not_provided(instance, "fmi3EvaluateDiscreteStates"); }

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    (void)clockReference, (void)activationTime;
    return not_provided(instance, "fmi3ActivateModelPartition");
}

