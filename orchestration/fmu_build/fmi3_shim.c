/* The binary of an FMI 3.0 FMU: checks the sizes of every get and set, forwards all else.

   pythonfmu3's binary ships beside this library as <modelIdentifier>SHIM_INNER_SUFFIX and does the
   work. This library is <modelIdentifier>.so; it exports every function of the FMI 3.0 standard and
   forwards each call to the same function of pythonfmu3's binary, with one exception: a get or set
   (any type) whose nValues is not the number of elements of its value references (the table
   resources/SHIM_SIZES_FILE, written at build time from the modelDescription: "vr size name" per
   line) is answered fmi3Error with a logged message naming each variable and its size, and the inner
   binary is not called, so the instance is unchanged. pythonfmu3 0.3.4 cannot do this itself: it
   never hands nValues of a get to Python (too many values: a Python exception left set; too few:
   silent truncation) and turns every Python exception into fmi3Fatal (docs/reliability.md).

   Depends on libc and libdl only. Built by orchestration/fmu_build/shim.py with the standard's
   headers (fmi3Functions.h), which SHIM_INNER_SUFFIX and SHIM_SIZES_FILE come from as -D flags. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"

/* every function of the standard but fmi3GetVersion, which answers here */
#define INNER_FUNCTIONS(X)                                                                              \
    X(SetDebugLogging) X(InstantiateModelExchange) X(InstantiateCoSimulation)                          \
    X(InstantiateScheduledExecution) X(FreeInstance) X(EnterInitializationMode)                         \
    X(ExitInitializationMode) X(EnterEventMode) X(Terminate) X(Reset)                                   \
    X(GetFloat32) X(GetFloat64) X(GetInt8) X(GetUInt8) X(GetInt16) X(GetUInt16) X(GetInt32)            \
    X(GetUInt32) X(GetInt64) X(GetUInt64) X(GetBoolean) X(GetString) X(GetBinary) X(GetClock)           \
    X(SetFloat32) X(SetFloat64) X(SetInt8) X(SetUInt8) X(SetInt16) X(SetUInt16) X(SetInt32)            \
    X(SetUInt32) X(SetInt64) X(SetUInt64) X(SetBoolean) X(SetString) X(SetBinary) X(SetClock)           \
    X(GetNumberOfVariableDependencies) X(GetVariableDependencies) X(GetFMUState) X(SetFMUState)         \
    X(FreeFMUState) X(SerializedFMUStateSize) X(SerializeFMUState) X(DeserializeFMUState)               \
    X(GetDirectionalDerivative) X(GetAdjointDerivative) X(EnterConfigurationMode)                       \
    X(ExitConfigurationMode) X(GetIntervalDecimal) X(GetIntervalFraction) X(GetShiftDecimal)            \
    X(GetShiftFraction) X(SetIntervalDecimal) X(SetIntervalFraction) X(SetShiftDecimal)                 \
    X(SetShiftFraction) X(EvaluateDiscreteStates) X(UpdateDiscreteStates) X(EnterContinuousTimeMode)    \
    X(CompletedIntegratorStep) X(SetTime) X(SetContinuousStates) X(GetContinuousStateDerivatives)       \
    X(GetEventIndicators) X(GetContinuousStates) X(GetNominalsOfContinuousStates)                       \
    X(GetNumberOfEventIndicators) X(GetNumberOfContinuousStates) X(EnterStepMode)                       \
    X(GetOutputDerivatives) X(DoStep) X(ActivateModelPartition)

#define DECLARE(name) static fmi3##name##TYPE *inner_##name;
INNER_FUNCTIONS(DECLARE)

static void *library;              /* pythonfmu3's binary */
static char load_error[4608];      /* why it is not loaded ("": it is) */

/* load pythonfmu3's binary from this library's folder when this library is loaded */
__attribute__((constructor)) static void load_inner(void) {
    Dl_info self;
    char path[4096];
    size_t n;
    if (!dladdr((void *) load_inner, &self) || !self.dli_fname) {
        snprintf(load_error, sizeof load_error, "cannot find the FMU's own binary");
        return;
    }
    n = strlen(self.dli_fname);
    if (n < 3 || n + sizeof SHIM_INNER_SUFFIX > sizeof path || strcmp(self.dli_fname + n - 3, ".so")) {
        snprintf(load_error, sizeof load_error, "unexpected binary name %s", self.dli_fname);
        return;
    }
    memcpy(path, self.dli_fname, n - 3);
    strcpy(path + n - 3, SHIM_INNER_SUFFIX);
    library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!library) {
        snprintf(load_error, sizeof load_error, "cannot load %s: %s", path, dlerror());
        return;
    }
#define RESOLVE(name)                                                                                   \
    if (!(inner_##name = (fmi3##name##TYPE *) dlsym(library, "fmi3" #name)) && !load_error[0])            \
        snprintf(load_error, sizeof load_error, "%s does not export fmi3" #name, path);
    INNER_FUNCTIONS(RESOLVE)
}

__attribute__((destructor)) static void unload_inner(void) {
    if (library) dlclose(library);
}

typedef struct {
    fmi3Instance inner;
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log;
    size_t count;   /* value references 0 .. count - 1 */
    size_t *sizes;  /* elements of each value reference (0: no such variable) */
    char **names;   /* each variable's name, pointing into text */
    char *text;     /* the size table as read */
} Shim;

#define INNER (((Shim *) instance)->inner)

static void report(fmi3LogMessageCallback log, fmi3InstanceEnvironment environment, const char *format, ...) {
    char message[1024];
    va_list args;
    if (!log) return;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    log(environment, fmi3Error, "logStatusError", message);
}

static void free_shim(Shim *s) {
    free(s->sizes);
    free(s->names);
    free(s->text);
    free(s);
}

/* the whole file at path, NUL-terminated (NULL: unreadable) */
static char *read_text(const char *path) {
    FILE *f = fopen(path, "rb");
    char *text = NULL;
    long size;
    if (!f) return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (size = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0
        && (text = malloc((size_t) size + 1)) && fread(text, 1, (size_t) size, f) == (size_t) size)
        text[size] = '\0';
    else {
        free(text);
        text = NULL;
    }
    fclose(f);
    return text;
}

/* parse "vr size name" lines of s->text into s->sizes and s->names; 0 on a malformed table */
static int parse_sizes(Shim *s) {
    char *line, *end;
    unsigned long vr, size;
    for (line = s->text; *line; line = end + 1) {
        vr = strtoul(line, &end, 10);
        if (end == line || vr >= 1000000 || !(end = strchr(end, '\n'))) return 0;
        s->count = vr + 1 > s->count ? vr + 1 : s->count;
    }
    s->sizes = calloc(s->count ? s->count : 1, sizeof *s->sizes);
    s->names = calloc(s->count ? s->count : 1, sizeof *s->names);
    if (!s->sizes || !s->names) return 0;
    for (line = s->text; *line; line = end + 1) {
        vr = strtoul(line, &end, 10);
        size = strtoul(end, &end, 10);
        if (*end++ != ' ' || size == 0) return 0;
        s->sizes[vr] = size;
        s->names[vr] = end;
        if (!(end = strchr(end, '\n'))) return 0;
        *end = '\0';
    }
    return 1;
}

static Shim *new_shim(fmi3String resourcePath, fmi3InstanceEnvironment environment, fmi3LogMessageCallback log) {
    char path[4096];
    Shim *s;
    if (load_error[0]) {
        report(log, environment, "fmi3Instantiate: %s", load_error);
        return NULL;
    }
    if (!resourcePath) {
        report(log, environment, "fmi3Instantiate: no resourcePath given (the FMU's code is in resources/)");
        return NULL;
    }
    if (!strncmp(resourcePath, "file://", 7)) resourcePath += 7;
    snprintf(path, sizeof path, "%s%s%s", resourcePath,
             resourcePath[0] && resourcePath[strlen(resourcePath) - 1] == '/' ? "" : "/", SHIM_SIZES_FILE);
    if (!(s = calloc(1, sizeof *s))) return NULL;
    s->environment = environment;
    s->log = log;
    if (!(s->text = read_text(path)) || !parse_sizes(s)) {
        report(log, environment, "fmi3Instantiate: %s is missing or damaged (lines of: valueReference size name)", path);
        free_shim(s);
        return NULL;
    }
    return s;
}

static Shim *started(Shim *s, fmi3Instance inner) {
    if (s && !(s->inner = inner)) {
        free_shim(s);
        return NULL;
    }
    return s;
}

/* fmi3OK if nValues is the number of elements of the value references, else a logged fmi3Error */
static fmi3Status check(const Shim *s, const char *call, const fmi3ValueReference vr[], size_t nvr,
                        size_t nValues, const char *verb) {
    char list[700] = "";
    size_t i, want = 0, used = 0;
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= s->count || !s->sizes[vr[i]]) {
            report(s->log, s->environment, "%s: no variable has valueReference %u; nothing was %s", call,
                   (unsigned) vr[i], verb);
            return fmi3Error;
        }
        want += s->sizes[vr[i]];
        if (used < sizeof list)
            used += (size_t) snprintf(list + used, sizeof list - used, "%s'%s' (%zu value%s)", i ? ", " : "",
                                      s->names[vr[i]], s->sizes[vr[i]], s->sizes[vr[i]] == 1 ? "" : "s");
    }
    if (want == nValues) return fmi3OK;
    report(s->log, s->environment, "%s: %s %s given %zu value%s, not %zu; nothing was %s", call,
           nvr ? list : "no variable", nvr == 1 ? "was" : "were", nValues, nValues == 1 ? "" : "s", want, verb);
    return fmi3Error;
}

/* ---- the standard's functions ---------------------------------------------------------------- */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
        fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
        fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage) {
    Shim *s = new_shim(resourcePath, instanceEnvironment, logMessage);
    return started(s, s ? inner_InstantiateModelExchange(instanceName, instantiationToken, resourcePath, visible,
                                                         loggingOn, instanceEnvironment, logMessage) : NULL);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
        fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
        fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
        size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
        fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    Shim *s = new_shim(resourcePath, instanceEnvironment, logMessage);
    return started(s, s ? inner_InstantiateCoSimulation(instanceName, instantiationToken, resourcePath, visible,
                                                        loggingOn, eventModeUsed, earlyReturnAllowed,
                                                        requiredIntermediateVariables, nRequiredIntermediateVariables,
                                                        instanceEnvironment, logMessage, intermediateUpdate) : NULL);
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
        fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
        fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
        fmi3ClockUpdateCallback clockUpdate, fmi3LockPreemptionCallback lockPreemption,
        fmi3UnlockPreemptionCallback unlockPreemption) {
    Shim *s = new_shim(resourcePath, instanceEnvironment, logMessage);
    return started(s, s ? inner_InstantiateScheduledExecution(instanceName, instantiationToken, resourcePath,
                                                              visible, loggingOn, instanceEnvironment, logMessage,
                                                              clockUpdate, lockPreemption, unlockPreemption) : NULL);
}

void fmi3FreeInstance(fmi3Instance instance) {
    if (!instance) return;
    inner_FreeInstance(INNER);
    free_shim(instance);
}

/* gets and sets: checked, then forwarded */
#define CHECKED(name, verb, type)                                                                       \
    fmi3Status fmi3##name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, type values[], \
                          size_t nValues) {                                                            \
        if (check(instance, "fmi3" #name, vr, nvr, nValues, verb) != fmi3OK) return fmi3Error;         \
        return inner_##name(INNER, vr, nvr, values, nValues);                                          \
    }
#define GET_SET(type) CHECKED(Get##type, "read", fmi3##type) CHECKED(Set##type, "set", const fmi3##type)
GET_SET(Float32) GET_SET(Float64) GET_SET(Int8) GET_SET(UInt8) GET_SET(Int16) GET_SET(UInt16)
GET_SET(Int32) GET_SET(UInt32) GET_SET(Int64) GET_SET(UInt64) GET_SET(Boolean) GET_SET(String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, size_t valueSizes[],
                         fmi3Binary values[], size_t nValues) {
    if (check(instance, "fmi3GetBinary", vr, nvr, nValues, "read") != fmi3OK) return fmi3Error;
    return inner_GetBinary(INNER, vr, nvr, valueSizes, values, nValues);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    if (check(instance, "fmi3SetBinary", vr, nvr, nValues, "set") != fmi3OK) return fmi3Error;
    return inner_SetBinary(INNER, vr, nvr, valueSizes, values, nValues);
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues) {
    if (check(instance, "fmi3GetOutputDerivatives", vr, nvr, nValues, "read") != fmi3OK) return fmi3Error;
    return inner_GetOutputDerivatives(INNER, vr, nvr, orders, values, nValues);
}

/* everything else: forwarded with the inner instance */
#define FORWARD(name, params, args) fmi3Status fmi3##name params { return inner_##name args; }
#define FORWARD0(name) FORWARD(name, (fmi3Instance instance), (INNER))

FORWARD(SetDebugLogging, (fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
        const fmi3String categories[]), (INNER, loggingOn, nCategories, categories))
FORWARD(EnterInitializationMode, (fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
        fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime),
        (INNER, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime))
FORWARD0(ExitInitializationMode) FORWARD0(EnterEventMode) FORWARD0(Terminate) FORWARD0(Reset)
FORWARD0(EnterConfigurationMode) FORWARD0(ExitConfigurationMode) FORWARD0(EvaluateDiscreteStates)
FORWARD0(EnterContinuousTimeMode) FORWARD0(EnterStepMode)
FORWARD(GetClock, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Clock values[]),
        (INNER, vr, nvr, values))
FORWARD(SetClock, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock values[]),
        (INNER, vr, nvr, values))
FORWARD(GetNumberOfVariableDependencies, (fmi3Instance instance, fmi3ValueReference valueReference,
        size_t *nDependencies), (INNER, valueReference, nDependencies))
FORWARD(GetVariableDependencies, (fmi3Instance instance, fmi3ValueReference dependent,
        size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
        size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[], size_t nDependencies),
        (INNER, dependent, elementIndicesOfDependent, independents, elementIndicesOfIndependents,
         dependencyKinds, nDependencies))
FORWARD(GetFMUState, (fmi3Instance instance, fmi3FMUState *FMUState), (INNER, FMUState))
FORWARD(SetFMUState, (fmi3Instance instance, fmi3FMUState FMUState), (INNER, FMUState))
FORWARD(FreeFMUState, (fmi3Instance instance, fmi3FMUState *FMUState), (INNER, FMUState))
FORWARD(SerializedFMUStateSize, (fmi3Instance instance, fmi3FMUState FMUState, size_t *size),
        (INNER, FMUState, size))
FORWARD(SerializeFMUState, (fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
        size_t size), (INNER, FMUState, serializedState, size))
FORWARD(DeserializeFMUState, (fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
        fmi3FMUState *FMUState), (INNER, serializedState, size, FMUState))
FORWARD(GetDirectionalDerivative, (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
        fmi3Float64 sensitivity[], size_t nSensitivity),
        (INNER, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed, sensitivity, nSensitivity))
FORWARD(GetAdjointDerivative, (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
        fmi3Float64 sensitivity[], size_t nSensitivity),
        (INNER, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed, sensitivity, nSensitivity))
FORWARD(GetIntervalDecimal, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]), (INNER, vr, nvr, intervals, qualifiers))
FORWARD(GetIntervalFraction, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]),
        (INNER, vr, nvr, counters, resolutions, qualifiers))
FORWARD(GetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 shifts[]),
        (INNER, vr, nvr, shifts))
FORWARD(GetShiftFraction, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        fmi3UInt64 counters[], fmi3UInt64 resolutions[]), (INNER, vr, nvr, counters, resolutions))
FORWARD(SetIntervalDecimal, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        const fmi3Float64 intervals[]), (INNER, vr, nvr, intervals))
FORWARD(SetIntervalFraction, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]), (INNER, vr, nvr, counters, resolutions))
FORWARD(SetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        const fmi3Float64 shifts[]), (INNER, vr, nvr, shifts))
FORWARD(SetShiftFraction, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]), (INNER, vr, nvr, counters, resolutions))
FORWARD(UpdateDiscreteStates, (fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
        fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
        fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime),
        (INNER, discreteStatesNeedUpdate, terminateSimulation, nominalsOfContinuousStatesChanged,
         valuesOfContinuousStatesChanged, nextEventTimeDefined, nextEventTime))
FORWARD(CompletedIntegratorStep, (fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
        fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation),
        (INNER, noSetFMUStatePriorToCurrentPoint, enterEventMode, terminateSimulation))
FORWARD(SetTime, (fmi3Instance instance, fmi3Float64 time), (INNER, time))
FORWARD(SetContinuousStates, (fmi3Instance instance, const fmi3Float64 continuousStates[], size_t nContinuousStates),
        (INNER, continuousStates, nContinuousStates))
FORWARD(GetContinuousStateDerivatives, (fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates),
        (INNER, derivatives, nContinuousStates))
FORWARD(GetEventIndicators, (fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators),
        (INNER, eventIndicators, nEventIndicators))
FORWARD(GetContinuousStates, (fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates),
        (INNER, continuousStates, nContinuousStates))
FORWARD(GetNominalsOfContinuousStates, (fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates),
        (INNER, nominals, nContinuousStates))
FORWARD(GetNumberOfEventIndicators, (fmi3Instance instance, size_t *nEventIndicators), (INNER, nEventIndicators))
FORWARD(GetNumberOfContinuousStates, (fmi3Instance instance, size_t *nContinuousStates), (INNER, nContinuousStates))
FORWARD(DoStep, (fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
        fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
        fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime),
        (INNER, currentCommunicationPoint, communicationStepSize, noSetFMUStatePriorToCurrentPoint,
         eventHandlingNeeded, terminateSimulation, earlyReturn, lastSuccessfulTime))
FORWARD(ActivateModelPartition, (fmi3Instance instance, fmi3ValueReference clockReference,
        fmi3Float64 activationTime), (INNER, clockReference, activationTime))
