/* The binary of an FMI 3.0 FMU: checks every get and set, and what pythonfmu3's binary cannot survive.

   pythonfmu3's binary ships beside this library as <modelIdentifier>SHIM_INNER_SUFFIX and does the
   work. This library is <modelIdentifier>.so; it exports every function of the FMI 3.0 standard and
   forwards each call to the same function of pythonfmu3's binary, except:

   - a get or set whose nValues is not the number of elements of its value references, or whose type
     is not the type of each variable (a Float32 get of a Float64 variable), is answered fmi3Error
     with a logged message naming each variable, and the inner binary is not called, so the instance
     is unchanged. The sizes and types come from the table resources/SHIM_SIZES_FILE, written at build
     time from the modelDescription ("vr size type name" per line). pythonfmu3 0.3.4 cannot do this
     itself: it never hands nValues of a get to Python (too many values: a Python exception left set;
     too few: silent truncation), turns every Python exception into fmi3Fatal, and aborts the host
     (std::logic_error "not implemented") on any call of Float32, the 8- and 16-bit integers, UInt32,
     Binary or Clock;
   - the other functions pythonfmu3 0.3.4 leaves unimplemented (they abort the host too) answer
     fmi3Error with a logged message (REFUSED below): the FMUs declare none of what they serve;
   - instantiation fails with a logged message, before pythonfmu3's binary is called, when the size
     table is missing, damaged or not a regular file (it is never read from a FIFO or a device), when
     resourcePath is too long for a path, or when resources/slavemodule.txt does not name a script
     resources/<module>.py: pythonfmu3's binary then hangs for ever (it throws out of the import with
     Python's lock still held).

   Depends on libc and libdl only. Built by orchestration/fmu_build/shim.py with the standard's
   headers (fmi3Functions.h), which SHIM_INNER_SUFFIX and SHIM_SIZES_FILE come from as -D flags. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "fmi3Functions.h"

/* every function of the standard but fmi3GetVersion, which answers here, and the REFUSED ones */
#define INNER_FUNCTIONS(X)                                                                              \
    X(SetDebugLogging) X(InstantiateModelExchange) X(InstantiateCoSimulation)                          \
    X(FreeInstance) X(EnterInitializationMode)                                                          \
    X(ExitInitializationMode) X(EnterEventMode) X(Terminate) X(Reset)                                   \
    X(GetFloat32) X(GetFloat64) X(GetInt8) X(GetUInt8) X(GetInt16) X(GetUInt16) X(GetInt32)            \
    X(GetUInt32) X(GetInt64) X(GetUInt64) X(GetBoolean) X(GetString) X(GetBinary) X(GetClock)           \
    X(SetFloat32) X(SetFloat64) X(SetInt8) X(SetUInt8) X(SetInt16) X(SetUInt16) X(SetInt32)            \
    X(SetUInt32) X(SetInt64) X(SetUInt64) X(SetBoolean) X(SetString) X(SetBinary) X(SetClock)           \
    X(GetFMUState) X(SetFMUState)                                                                       \
    X(FreeFMUState) X(SerializedFMUStateSize) X(SerializeFMUState) X(DeserializeFMUState)               \
    X(GetDirectionalDerivative) X(EnterConfigurationMode)                                               \
    X(ExitConfigurationMode) X(UpdateDiscreteStates) X(EnterContinuousTimeMode)                        \
    X(CompletedIntegratorStep) X(SetTime) X(SetContinuousStates) X(GetContinuousStateDerivatives)       \
    X(GetEventIndicators) X(GetContinuousStates) X(GetNominalsOfContinuousStates)                       \
    X(GetNumberOfEventIndicators) X(GetNumberOfContinuousStates) X(EnterStepMode)                       \
    X(GetOutputDerivatives) X(DoStep)

/* the types of variables, each with its get and set */
#define TYPES(X) X(Float32) X(Float64) X(Int8) X(UInt8) X(Int16) X(UInt16) X(Int32) X(UInt32) X(Int64) \
    X(UInt64) X(Boolean) X(String) X(Binary) X(Clock)
#define TYPE_ENUM(type) TYPE_##type,
enum { TYPES(TYPE_ENUM) TYPE_COUNT };
#define TYPE_NAME(type) #type,
static const char *const type_names[] = {TYPES(TYPE_NAME)};

#define MAX_VR 1000000          /* value references of the table: 0 .. MAX_VR - 1 */
#define MAX_SIZE 1000000        /* elements of one variable: a sum over a call's nvr variables stays exact */
#define MAX_TABLE (16L << 20)   /* bytes of the size table (about 40 per variable) */
#define MAX_PATH 4096           /* bytes of a path, with its NUL (Linux's PATH_MAX) */

#define DECLARE(name) static fmi3##name##TYPE *inner_##name;
INNER_FUNCTIONS(DECLARE)

static void *library;              /* pythonfmu3's binary */
static char load_error[4608];      /* why it is not loaded ("": it is) */

/* load pythonfmu3's binary from this library's folder when this library is loaded */
__attribute__((constructor)) static void load_inner(void) {
    Dl_info self;
    char path[MAX_PATH];
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
    size_t count;          /* value references 0 .. count - 1 */
    size_t *sizes;         /* elements of each value reference (0: no such variable) */
    unsigned char *types;  /* the type of each (TYPE_...) */
    char **names;          /* each variable's name, pointing into text */
    char *text;            /* the size table as read */
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
    free(s->types);
    free(s->names);
    free(s->text);
    free(s);
}

/* the whole regular file at path (1 to limit bytes, no NUL byte), NUL-terminated; NULL with why[] said
   otherwise. Opened without blocking and without following a link: a FIFO or a device is refused, never read. */
static char *read_file(const char *path, long limit, char *why, size_t why_size) {
    struct stat st;
    char *text = NULL;
    ssize_t got = 0, n = 1;
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) {
        if (errno == ELOOP)
            snprintf(why, why_size, "is a symbolic link, not a regular file");
        else
            snprintf(why, why_size, "cannot be opened (%s)", strerror(errno));
        return NULL;
    }
    if (fstat(fd, &st) || !S_ISREG(st.st_mode))
        snprintf(why, why_size, "is not a regular file");
    else if (st.st_size == 0)
        snprintf(why, why_size, "is empty");
    else if (st.st_size > limit)
        snprintf(why, why_size, "has %ld bytes, more than the %ld accepted", (long) st.st_size, limit);
    else if (!(text = malloc((size_t) st.st_size + 1)))
        snprintf(why, why_size, "does not fit in memory");
    else {
        while (got < st.st_size && (n = read(fd, text + got, (size_t) (st.st_size - got))) > 0) got += n;
        text[got] = '\0';
        if (n < 0)
            snprintf(why, why_size, "cannot be read (%s)", strerror(errno));
        else if (got != st.st_size)
            snprintf(why, why_size, "changed while it was read");
        else if (strlen(text) != (size_t) got)
            snprintf(why, why_size, "holds a NUL byte (at byte %zu)", strlen(text));
        if (n < 0 || got != st.st_size || strlen(text) != (size_t) got) {
            free(text);
            text = NULL;
        }
    }
    close(fd);
    return text;
}

/* the decimal digits at *p as a number below limit, *p moved past them; -1: no digits (a sign), or too large */
static long number(char **p, long limit) {
    long n = 0;
    if (**p < '0' || **p > '9') return -1;
    for (; **p >= '0' && **p <= '9'; (*p)++)
        if ((n = n * 10 + (**p - '0')) >= limit) return -1;
    return n;
}

/* one line "vr size type name\n" at line: 0 and its fields (name NUL-terminated if store), or why[] it is not */
static int parse_line(char *line, int store, long *vr, long *size, int *type, char **name, char **end,
                      char *why, size_t why_size) {
    char *p = line;
    int t;
    *end = strchr(line, '\n');
    if (!*end) return snprintf(why, why_size, "its last line has no end"), -1;
    if ((*vr = number(&p, MAX_VR)) < 0 || *p++ != ' ')
        return snprintf(why, why_size, "a value reference is not a number from 0 to %d", MAX_VR - 1), -1;
    if ((*size = number(&p, MAX_SIZE + 1)) < 1 || *p++ != ' ')
        return snprintf(why, why_size, "the size of value reference %ld is not a number from 1 to %d", *vr,
                        MAX_SIZE), -1;
    for (t = 0; t < TYPE_COUNT; t++) {
        size_t n = strlen(type_names[t]);
        if (!strncmp(p, type_names[t], n) && p[n] == ' ') break;
    }
    if (t == TYPE_COUNT) return snprintf(why, why_size, "value reference %ld has no FMI 3 type", *vr), -1;
    *type = t;
    *name = p + strlen(type_names[t]) + 1;
    if (*name == *end) return snprintf(why, why_size, "value reference %ld has no name", *vr), -1;
    if (store) **end = '\0';
    return 0;
}

/* s->sizes, s->types and s->names from the lines of s->text; 0, or why[] the table is damaged */
static int parse_sizes(Shim *s, char *why, size_t why_size) {
    char *line, *end, *name;
    long vr, size;
    int type, pass;
    for (pass = 0; pass < 2; pass++) {  /* the highest value reference first, then the entries */
        for (line = s->text; *line; line = end + 1) {
            if (parse_line(line, pass, &vr, &size, &type, &name, &end, why, why_size)) return -1;
            if (!pass) {
                s->count = (size_t) vr + 1 > s->count ? (size_t) vr + 1 : s->count;
                continue;
            }
            if (s->sizes[vr]) return snprintf(why, why_size, "value reference %ld comes twice", vr), -1;
            s->sizes[vr] = (size_t) size;
            s->types[vr] = (unsigned char) type;
            s->names[vr] = name;
        }
        if (!pass && (!(s->sizes = calloc(s->count, sizeof *s->sizes)) || !(s->types = calloc(s->count, 1))
                      || !(s->names = calloc(s->count, sizeof *s->names))))
            return snprintf(why, why_size, "does not fit in memory"), -1;
    }
    return 0;
}

/* resourcePath as a folder path (no "file://"), or NULL after a logged message: too long for the
   files this library and pythonfmu3 open in it */
static const char *resource_folder(fmi3String resourcePath, fmi3InstanceEnvironment environment,
                                   fmi3LogMessageCallback log) {
    static const size_t longest = sizeof "/slavemodule.txt" > sizeof "/" SHIM_SIZES_FILE
                                      ? sizeof "/slavemodule.txt" : sizeof "/" SHIM_SIZES_FILE;
    if (!resourcePath) {
        report(log, environment, "fmi3Instantiate: no resourcePath given (the FMU's code is in resources/)");
        return NULL;
    }
    if (!strncmp(resourcePath, "file://", 7)) resourcePath += 7;
    if (strlen(resourcePath) + longest > MAX_PATH) {
        report(log, environment, "fmi3Instantiate: the resourcePath is too long: %zu characters, where the "
               "paths of the files in it may have %zu at most", strlen(resourcePath), MAX_PATH - longest);
        return NULL;
    }
    return resourcePath;
}

/* "folder/name" in path[MAX_PATH] (a folder without its last '/' gets one); 0 if it does not fit */
static int join(char *path, const char *folder, const char *name) {
    size_t n = strlen(folder);
    return snprintf(path, MAX_PATH, "%s%s%s", folder, n && folder[n - 1] == '/' ? "" : "/", name) < MAX_PATH;
}

/* whether resources/slavemodule.txt names a script resources/<module>.py that is a regular file (else a
   logged message): pythonfmu3's binary imports that module and reads its class from that file, and hangs
   without them */
static int script_present(const char *folder, fmi3InstanceEnvironment environment, fmi3LogMessageCallback log) {
    char path[MAX_PATH], script[300], why[256];
    struct stat st;
    char *module;
    size_t n;
    int ok;
    join(path, folder, "slavemodule.txt");  /* fits: resource_folder */
    if (!(module = read_file(path, 255, why, sizeof why))) {
        report(log, environment, "fmi3Instantiate: %s, which names the module of the FMU's code, %s: the code "
               "cannot be imported", path, why);
        return 0;
    }
    n = strcspn(module, "\r\n");
    module[n] = '\0';
    if (!n || strspn(module, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_") != n) {
        report(log, environment, "fmi3Instantiate: %s does not name a module (a word of letters, digits and _): "
               "the FMU's code cannot be imported", path);
        free(module);
        return 0;
    }
    snprintf(script, sizeof script, "%s.py", module);  /* fits: at most 255 characters read */
    ok = join(path, folder, script) && !stat(path, &st) && S_ISREG(st.st_mode);
    if (!ok)
        report(log, environment, "fmi3Instantiate: %s, the FMU's script that resources/slavemodule.txt names, is "
               "missing: the FMU's code cannot be imported", path);
    free(module);
    return ok;
}

static Shim *new_shim(fmi3String resourcePath, fmi3InstanceEnvironment environment, fmi3LogMessageCallback log) {
    char path[MAX_PATH], why[256];
    const char *folder;
    Shim *s;
    if (load_error[0]) {
        report(log, environment, "fmi3Instantiate: %s", load_error);
        return NULL;
    }
    if (!(folder = resource_folder(resourcePath, environment, log)) || !script_present(folder, environment, log))
        return NULL;
    join(path, folder, SHIM_SIZES_FILE);  /* fits: resource_folder */
    if (!(s = calloc(1, sizeof *s))) return NULL;
    s->environment = environment;
    s->log = log;
    if (!(s->text = read_file(path, MAX_TABLE, why, sizeof why)) || parse_sizes(s, why, sizeof why)) {
        report(log, environment, "fmi3Instantiate: %s, the table of the variables' sizes, %s%s (lines of: "
               "valueReference size type name)", path, s->text ? "is damaged: " : "", why);
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

/* fmi3OK if every value reference is a variable of the call's type and nValues is the number of their
   elements, else a logged fmi3Error */
static fmi3Status check(const Shim *s, const char *call, int type, const fmi3ValueReference vr[], size_t nvr,
                        size_t nValues, const char *verb) {
    char list[700] = "";
    size_t i, want = 0, used = 0;  /* want <= nvr * MAX_SIZE: exact for any array a host can pass */
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= s->count || !s->sizes[vr[i]]) {
            report(s->log, s->environment, "%s: no variable has valueReference %u; nothing was %s", call,
                   (unsigned) vr[i], verb);
            return fmi3Error;
        }
        if (s->types[vr[i]] != type) {
            report(s->log, s->environment, "%s: '%s' is a %s variable, not %s; nothing was %s", call,
                   s->names[vr[i]], type_names[s->types[vr[i]]], type_names[type], verb);
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
    report(logMessage, instanceEnvironment, "fmi3InstantiateScheduledExecution: the FMU has no Scheduled Execution "
           "interface (its modelDescription declares none)");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    if (!instance) return;
    inner_FreeInstance(INNER);
    free_shim(instance);
}

/* gets and sets: checked, then forwarded */
#define CHECKED(name, verb, type, value)                                                                \
    fmi3Status fmi3##name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, value values[], \
                          size_t nValues) {                                                            \
        if (check(instance, "fmi3" #name, TYPE_##type, vr, nvr, nValues, verb) != fmi3OK) return fmi3Error; \
        return inner_##name(INNER, vr, nvr, values, nValues);                                          \
    }
#define GET_SET(type) CHECKED(Get##type, "read", type, fmi3##type) CHECKED(Set##type, "set", type, const fmi3##type)
GET_SET(Float32) GET_SET(Float64) GET_SET(Int8) GET_SET(UInt8) GET_SET(Int16) GET_SET(UInt16)
GET_SET(Int32) GET_SET(UInt32) GET_SET(Int64) GET_SET(UInt64) GET_SET(Boolean) GET_SET(String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, size_t valueSizes[],
                         fmi3Binary values[], size_t nValues) {
    if (check(instance, "fmi3GetBinary", TYPE_Binary, vr, nvr, nValues, "read") != fmi3OK) return fmi3Error;
    return inner_GetBinary(INNER, vr, nvr, valueSizes, values, nValues);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    if (check(instance, "fmi3SetBinary", TYPE_Binary, vr, nvr, nValues, "set") != fmi3OK) return fmi3Error;
    return inner_SetBinary(INNER, vr, nvr, valueSizes, values, nValues);
}

/* a clock is a scalar: one value per value reference */
fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Clock values[]) {
    if (check(instance, "fmi3GetClock", TYPE_Clock, vr, nvr, nvr, "read") != fmi3OK) return fmi3Error;
    return inner_GetClock(INNER, vr, nvr, values);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock values[]) {
    if (check(instance, "fmi3SetClock", TYPE_Clock, vr, nvr, nvr, "set") != fmi3OK) return fmi3Error;
    return inner_SetClock(INNER, vr, nvr, values);
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues) {
    if (check(instance, "fmi3GetOutputDerivatives", TYPE_Float64, vr, nvr, nValues, "read") != fmi3OK) return fmi3Error;
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
FORWARD0(EnterConfigurationMode) FORWARD0(ExitConfigurationMode)
FORWARD0(EnterContinuousTimeMode) FORWARD0(EnterStepMode)
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

/* what pythonfmu3 0.3.4 leaves unimplemented (it aborts the host) and these FMUs declare nothing of: refused */
#define REFUSED(name, params, why)                                                                      \
    fmi3Status fmi3##name params {                                                                      \
        const Shim *s = instance;                                                                       \
        report(s->log, s->environment, "fmi3" #name ": " why);                                          \
        return fmi3Error;                                                                               \
    }
#define NO_DEPENDENCIES "the FMU does not give dependencies per element (providesPerElementDependencies is " \
    "not declared; the modelDescription's ModelStructure lists them)"
#define NO_CLOCKS "the FMU has no clocks"

REFUSED(GetNumberOfVariableDependencies, (fmi3Instance instance, fmi3ValueReference valueReference,
        size_t *nDependencies), NO_DEPENDENCIES)
REFUSED(GetVariableDependencies, (fmi3Instance instance, fmi3ValueReference dependent,
        size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
        size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[], size_t nDependencies),
        NO_DEPENDENCIES)
REFUSED(GetAdjointDerivative, (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
        fmi3Float64 sensitivity[], size_t nSensitivity),
        "the FMU gives no adjoint derivatives (providesAdjointDerivatives is not declared)")
REFUSED(EvaluateDiscreteStates, (fmi3Instance instance),
        "the FMU does not evaluate discrete states (providesEvaluateDiscreteStates is not declared)")
REFUSED(ActivateModelPartition, (fmi3Instance instance, fmi3ValueReference clockReference,
        fmi3Float64 activationTime), "the FMU has no Scheduled Execution interface")
REFUSED(GetIntervalDecimal, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]), NO_CLOCKS)
REFUSED(GetIntervalFraction, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]), NO_CLOCKS)
REFUSED(GetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 shifts[]),
        NO_CLOCKS)
REFUSED(GetShiftFraction, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        fmi3UInt64 counters[], fmi3UInt64 resolutions[]), NO_CLOCKS)
REFUSED(SetIntervalDecimal, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        const fmi3Float64 intervals[]), NO_CLOCKS)
REFUSED(SetIntervalFraction, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]), NO_CLOCKS)
REFUSED(SetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        const fmi3Float64 shifts[]), NO_CLOCKS)
REFUSED(SetShiftFraction, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
        const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]), NO_CLOCKS)
