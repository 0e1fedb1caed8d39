/* PdController3: the PD controller of examples/pd_controller as an FMI 3.0 Co-Simulation FMU in plain C,
 * against the FMI 3.0 headers fmpy ships, for the tests of a foreign FMI 3.0 controller
 * (tests/support/fmi3_pd/__init__.py builds it). The example's FMI 2.0 code is included whole and each FMI
 * 3.0 call is made of its FMI 2.0 ones; value references 0 .. 12 are the example's, 13 is time. Every FMI
 * 3.0 function this FMU does not provide is exported too (fmpy looks each one up) and answers fmi3Error
 * with a logged message. */

#include <stdlib.h>

#include "fmi3Functions.h"
#include "../../../examples/pd_controller/pd_controller.c"

#define TIME_VR 13

typedef struct {
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log;
    fmi2Component inner;
} Wrapper;

/* The example's FMI 2.0 logger calls, passed on to the FMI 3.0 host's (the statuses have the same values). */
static void pass_on(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                    fmi2String message, ...) {
    const Wrapper *w = env;
    (void)name;
    if (w && w->log) w->log(w->environment, (fmi3Status)status, category, message);
}

static void *allocate(size_t n, size_t size) { return calloc(n, size); }

static fmi3Status refuse(fmi3Instance instance, const char *call) {
    const Wrapper *w = instance;
    if (w && w->log) w->log(w->environment, fmi3Error, "logStatusError", call);
    return fmi3Error;
}

static fmi3Status status3(fmi2Status status) { return (fmi3Status)status; }

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    (void)loggingOn, (void)nCategories, (void)categories;
    return instance ? fmi3OK : fmi3Error;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    (void)resourcePath, (void)eventModeUsed, (void)earlyReturnAllowed, (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables, (void)intermediateUpdate;
    Wrapper *w = calloc(1, sizeof(Wrapper));
    if (!w) return NULL;
    w->environment = instanceEnvironment;
    w->log = logMessage;
    const fmi2CallbackFunctions functions = {.logger = pass_on, .allocateMemory = allocate, .freeMemory = free,
                                             .componentEnvironment = w};
    w->inner = fmi2Instantiate(instanceName, fmi2CoSimulation, instantiationToken, NULL, &functions, visible,
                               loggingOn);
    if (!w->inner) {
        free(w);
        return NULL;
    }
    return w;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", "Co-Simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
    return fmi3InstantiateModelExchange(instanceName, instantiationToken, resourcePath, visible, loggingOn,
                                        instanceEnvironment, logMessage);
}

void fmi3FreeInstance(fmi3Instance instance) {
    Wrapper *w = instance;
    if (!w) return;
    fmi2FreeInstance(w->inner);
    free(w);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    const Wrapper *w = instance;
    if (!w) return fmi3Error;
    fmi2Status status = fmi2SetupExperiment(w->inner, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime);
    return status3(status == fmi2OK ? fmi2EnterInitializationMode(w->inner) : status);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    return instance ? status3(fmi2ExitInitializationMode(((Wrapper *)instance)->inner)) : fmi3Error;
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    return instance ? status3(fmi2Terminate(((Wrapper *)instance)->inner)) : fmi3Error;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    return instance ? status3(fmi2Reset(((Wrapper *)instance)->inner)) : fmi3Error;
}

/* One value per value reference (every variable is a scalar); time's is the last communication point. */
fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    const Wrapper *w = instance;
    if (!w) return fmi3Error;
    if (nValues != nValueReferences) return refuse(instance, "fmi3GetFloat64: nValues is not nValueReferences");
    for (size_t i = 0; i < nValueReferences; i++) {
        fmi2Status status = valueReferences[i] == TIME_VR
            ? fmi2GetRealStatus(w->inner, fmi2LastSuccessfulTime, &values[i])
            : fmi2GetReal(w->inner, &valueReferences[i], 1, &values[i]);
        if (status != fmi2OK) return status3(status);
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    const Wrapper *w = instance;
    if (!w) return fmi3Error;
    if (nValues != nValueReferences) return refuse(instance, "fmi3SetFloat64: nValues is not nValueReferences");
    return status3(fmi2SetReal(w->inner, valueReferences, nValueReferences, values));
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime) {
    const Wrapper *w = instance;
    if (!w) return fmi3Error;
    *eventHandlingNeeded = *terminateSimulation = *earlyReturn = fmi3False;
    fmi2Status status = fmi2DoStep(w->inner, currentCommunicationPoint, communicationStepSize,
                                   noSetFMUStatePriorToCurrentPoint);
    fmi2GetRealStatus(w->inner, fmi2LastSuccessfulTime, lastSuccessfulTime);
    return status3(status);
}

/* ---- What this FMU does not provide: fmi3Error, logged ---- */

#pragma GCC diagnostic ignored "-Wunused-parameter"
#define REFUSE(name, parameters) \
    fmi3Status name parameters { return refuse(instance, #name " is not provided by this FMU"); }

REFUSE(fmi3EnterEventMode, (fmi3Instance instance))
REFUSE(fmi3GetFloat32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float32 values[], size_t nValues))
REFUSE(fmi3GetInt8, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int8 values[], size_t nValues))
REFUSE(fmi3GetUInt8, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt8 values[], size_t nValues))
REFUSE(fmi3GetInt16, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int16 values[], size_t nValues))
REFUSE(fmi3GetUInt16, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt16 values[], size_t nValues))
REFUSE(fmi3GetInt32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int32 values[], size_t nValues))
REFUSE(fmi3GetUInt32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt32 values[], size_t nValues))
REFUSE(fmi3GetInt64, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int64 values[], size_t nValues))
REFUSE(fmi3GetUInt64, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 values[], size_t nValues))
REFUSE(fmi3GetBoolean, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Boolean values[], size_t nValues))
REFUSE(fmi3GetString, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3String values[], size_t nValues))
REFUSE(fmi3GetBinary, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, size_t valueSizes[], fmi3Binary values[], size_t nValues))
REFUSE(fmi3GetClock, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Clock values[]))
REFUSE(fmi3SetFloat32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float32 values[], size_t nValues))
REFUSE(fmi3SetInt8, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int8 values[], size_t nValues))
REFUSE(fmi3SetUInt8, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt8 values[], size_t nValues))
REFUSE(fmi3SetInt16, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int16 values[], size_t nValues))
REFUSE(fmi3SetUInt16, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt16 values[], size_t nValues))
REFUSE(fmi3SetInt32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int32 values[], size_t nValues))
REFUSE(fmi3SetUInt32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt32 values[], size_t nValues))
REFUSE(fmi3SetInt64, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int64 values[], size_t nValues))
REFUSE(fmi3SetUInt64, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 values[], size_t nValues))
REFUSE(fmi3SetBoolean, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Boolean values[], size_t nValues))
REFUSE(fmi3SetString, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3String values[], size_t nValues))
REFUSE(fmi3SetBinary, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const size_t valueSizes[], const fmi3Binary values[], size_t nValues))
REFUSE(fmi3SetClock, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Clock values[]))
REFUSE(fmi3GetNumberOfVariableDependencies, (fmi3Instance instance, fmi3ValueReference valueReference, size_t* nDependencies))
REFUSE(fmi3GetVariableDependencies, (fmi3Instance instance, fmi3ValueReference dependent, size_t elementIndicesOfDependent[], fmi3ValueReference independents[], size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[], size_t nDependencies))
REFUSE(fmi3GetFMUState, (fmi3Instance instance, fmi3FMUState* FMUState))
REFUSE(fmi3SetFMUState, (fmi3Instance instance, fmi3FMUState FMUState))
REFUSE(fmi3FreeFMUState, (fmi3Instance instance, fmi3FMUState* FMUState))
REFUSE(fmi3SerializedFMUStateSize, (fmi3Instance instance, fmi3FMUState FMUState, size_t* size))
REFUSE(fmi3SerializeFMUState, (fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size))
REFUSE(fmi3DeserializeFMUState, (fmi3Instance instance, const fmi3Byte serializedState[], size_t size, fmi3FMUState* FMUState))
REFUSE(fmi3GetDirectionalDerivative, (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
REFUSE(fmi3GetAdjointDerivative, (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
REFUSE(fmi3EnterConfigurationMode, (fmi3Instance instance))
REFUSE(fmi3ExitConfigurationMode, (fmi3Instance instance))
REFUSE(fmi3GetIntervalDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]))
REFUSE(fmi3GetIntervalFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]))
REFUSE(fmi3GetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float64 shifts[]))
REFUSE(fmi3GetShiftFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]))
REFUSE(fmi3SetIntervalDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float64 intervals[]))
REFUSE(fmi3SetIntervalFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]))
REFUSE(fmi3SetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float64 shifts[]))
REFUSE(fmi3SetShiftFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]))
REFUSE(fmi3EvaluateDiscreteStates, (fmi3Instance instance))
REFUSE(fmi3UpdateDiscreteStates, (fmi3Instance instance, fmi3Boolean* discreteStatesNeedUpdate, fmi3Boolean* terminateSimulation, fmi3Boolean* nominalsOfContinuousStatesChanged, fmi3Boolean* valuesOfContinuousStatesChanged, fmi3Boolean* nextEventTimeDefined, fmi3Float64* nextEventTime))
REFUSE(fmi3EnterContinuousTimeMode, (fmi3Instance instance))
REFUSE(fmi3CompletedIntegratorStep, (fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* enterEventMode, fmi3Boolean* terminateSimulation))
REFUSE(fmi3SetTime, (fmi3Instance instance, fmi3Float64 time))
REFUSE(fmi3SetContinuousStates, (fmi3Instance instance, const fmi3Float64 continuousStates[], size_t nContinuousStates))
REFUSE(fmi3GetContinuousStateDerivatives, (fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates))
REFUSE(fmi3GetEventIndicators, (fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators))
REFUSE(fmi3GetContinuousStates, (fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates))
REFUSE(fmi3GetNominalsOfContinuousStates, (fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates))
REFUSE(fmi3GetNumberOfEventIndicators, (fmi3Instance instance, size_t* nEventIndicators))
REFUSE(fmi3GetNumberOfContinuousStates, (fmi3Instance instance, size_t* nContinuousStates))
REFUSE(fmi3EnterStepMode, (fmi3Instance instance))
REFUSE(fmi3GetOutputDerivatives, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues))
REFUSE(fmi3ActivateModelPartition, (fmi3Instance instance, fmi3ValueReference clockReference, fmi3Float64 activationTime))
