/* PdController: a saturated PD joint controller for a two-link arm, an FMI 2.0 Co-Simulation FMU
 * in plain C.
 *
 *   u = Kp (q_ref - q) + Kd (dq_ref - dq), then scaled radially so that ||u||_2 <= umax.
 *
 * Inputs q1 q2 (rad), dq1 dq2 (rad/s), q1_ref q2_ref (rad), dq1_ref dq2_ref (rad/s, 0 if not
 * connected); parameters Kp (N.m/rad), Kd (N.m.s/rad), umax (N.m); outputs u1 u2 (N.m). The outputs
 * follow the inputs at once (direct feedthrough): they are computed again on every fmi2SetReal and
 * fmi2DoStep. Everything lives in the instance, so instances never share anything.
 *
 * build.py compiles this file against the FMI 2.0 headers fmpy ships and passes the guid of
 * modelDescription.xml as PD_GUID; the value references below are those of modelDescription.xml. */

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "fmi2Functions.h"

#ifndef PD_GUID
#error "compile with -DPD_GUID=\"{...}\", the guid of modelDescription.xml (build.py does)"
#endif

/* ---- Variables: value reference = position in this list (modelDescription.xml) ---- */

enum { Q1, Q2, DQ1, DQ2, Q1_REF, Q2_REF, DQ1_REF, DQ2_REF, KP, KD, UMAX, U1, U2, N_VARS };

static const char *const NAMES[N_VARS] = {"q1", "q2", "dq1", "dq2", "q1_ref", "q2_ref", "dq1_ref",
                                          "dq2_ref", "Kp", "Kd", "umax", "u1", "u2"};

/* the start values of modelDescription.xml: inputs 0, the parameters' defaults */
static const fmi2Real START[N_VARS] = {[KP] = 60.0, [KD] = 15.0, [UMAX] = 4.0};

/* ---- The instance: the states of FMI 2.0 section 4.2.4 this FMU tells apart, and its values ---- */

typedef enum { INSTANTIATED, INITIALIZATION_MODE, STEP_MODE, TERMINATED } State;

static const char *const STATE_NAMES[] = {"Instantiated", "Initialization Mode", "Step Mode",
                                          "Terminated"};

typedef struct {
    fmi2CallbackLogger logger;
    fmi2CallbackFreeMemory freeMemory;
    fmi2ComponentEnvironment environment;
    char name[128];
    State state;
    fmi2Real time;
    fmi2Real r[N_VARS];
} Instance;

/* Log an error through the host's logger (category logStatusError) and return fmi2Error. The
 * message is formatted here, so the host receives it without format directives of ours. */
static fmi2Status fail(const Instance *inst, const char *format, ...) {
    char message[256];
    va_list args;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    if (inst->logger) inst->logger(inst->environment, inst->name, fmi2Error, "logStatusError", message);
    return fmi2Error;
}

/* Refuse a call made in a state where FMI 2.0 does not allow it. */
static fmi2Status require(const Instance *inst, unsigned allowed, const char *call) {
    if (allowed & (1u << inst->state)) return fmi2OK;
    return fail(inst, "%s is not allowed in %s", call, STATE_NAMES[inst->state]);
}

#define IN(s) (1u << (s))

/* ---- The controller ---- */

static void update_outputs(Instance *inst) {
    fmi2Real *r = inst->r;
    fmi2Real u1 = r[KP] * (r[Q1_REF] - r[Q1]) + r[KD] * (r[DQ1_REF] - r[DQ1]);
    fmi2Real u2 = r[KP] * (r[Q2_REF] - r[Q2]) + r[KD] * (r[DQ2_REF] - r[DQ2]);
    fmi2Real norm = hypot(u1, u2);
    if (norm > r[UMAX]) { /* keep the direction, shorten to umax */
        u1 *= r[UMAX] / norm;
        u2 *= r[UMAX] / norm;
    }
    r[U1] = u1;
    r[U2] = u2;
}

/* Why a value cannot go to variable vr < N_VARS (NULL if it can). */
static const char *refusal(fmi2ValueReference vr, fmi2Real value) {
    if (vr == U1 || vr == U2) return "an output cannot be set";
    if (vr == KP || vr == KD) return isfinite(value) && value >= 0 ? NULL : "must be finite and >= 0";
    if (vr == UMAX) return isfinite(value) && value > 0 ? NULL : "must be finite and > 0";
    return NULL;
}

/* ---- Platform and version, logging (FMI 2.0 section 2.1.4, 2.1.5) ---- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)loggingOn, (void)nCategories, (void)categories; /* errors are always logged */
    return c ? fmi2OK : fmi2Error;
}

/* ---- Creation and destruction (FMI 2.0 section 2.1.5) ---- */

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)fmuResourceLocation, (void)visible, (void)loggingOn;
    if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
    Instance early = {.logger = functions->logger, .environment = functions->componentEnvironment};
    snprintf(early.name, sizeof early.name, "%s", instanceName ? instanceName : "");
    if (fmuType != fmi2CoSimulation) {
        fail(&early, "fmi2Instantiate: this FMU supports Co-Simulation only");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, PD_GUID) != 0) {
        fail(&early, "fmi2Instantiate: guid %s is not this binary's %s", fmuGUID ? fmuGUID : "(null)", PD_GUID);
        return NULL;
    }
    Instance *inst = functions->allocateMemory(1, sizeof(Instance));
    if (!inst) {
        fail(&early, "fmi2Instantiate: out of memory");
        return NULL;
    }
    *inst = early;
    inst->freeMemory = functions->freeMemory;
    fmi2Reset(inst);
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = c;
    if (inst) inst->freeMemory(inst);
}

/* ---- Initialization, termination and reset (FMI 2.0 section 2.1.6) ---- */

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    Instance *inst = c;
    if (!inst) return fmi2Error;
    if (require(inst, IN(INSTANTIATED), "fmi2SetupExperiment") != fmi2OK) return fmi2Error;
    inst->time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Instance *inst = c;
    if (!inst) return fmi2Error;
    if (require(inst, IN(INSTANTIATED), "fmi2EnterInitializationMode") != fmi2OK) return fmi2Error;
    inst->state = INITIALIZATION_MODE;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *inst = c;
    if (!inst) return fmi2Error;
    if (require(inst, IN(INITIALIZATION_MODE), "fmi2ExitInitializationMode") != fmi2OK) return fmi2Error;
    inst->state = STEP_MODE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    Instance *inst = c;
    if (!inst) return fmi2Error;
    if (require(inst, IN(STEP_MODE), "fmi2Terminate") != fmi2OK) return fmi2Error;
    inst->state = TERMINATED;
    return fmi2OK;
}

/* Back to the state after fmi2Instantiate: every variable at its start value. */
fmi2Status fmi2Reset(fmi2Component c) {
    Instance *inst = c;
    if (!inst) return fmi2Error;
    memcpy(inst->r, START, sizeof START);
    inst->time = 0.0;
    inst->state = INSTANTIATED;
    update_outputs(inst);
    return fmi2OK;
}

/* ---- Getting and setting variable values (FMI 2.0 section 2.1.7) ---- */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Instance *inst = c;
    if (!inst) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= N_VARS) return fail(inst, "fmi2GetReal: no Real variable has value reference %u", vr[i]);
        value[i] = inst->r[vr[i]];
    }
    return fmi2OK;
}

/* All or nothing: every value is checked before any is stored. */
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Instance *inst = c;
    if (!inst) return fmi2Error;
    if (require(inst, IN(INSTANTIATED) | IN(INITIALIZATION_MODE) | IN(STEP_MODE), "fmi2SetReal") != fmi2OK)
        return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= N_VARS) return fail(inst, "fmi2SetReal: no Real variable has value reference %u", vr[i]);
        const char *why = refusal(vr[i], value[i]);
        if (why) return fail(inst, "fmi2SetReal: %s = %g refused: %s", NAMES[vr[i]], value[i], why);
    }
    for (size_t i = 0; i < nvr; i++) inst->r[vr[i]] = value[i];
    update_outputs(inst);
    return fmi2OK;
}

/* This FMU has Real variables only: any value reference of another type is refused. */
static fmi2Status no_variable(fmi2Component c, size_t nvr, const fmi2ValueReference vr[], const char *call) {
    Instance *inst = c;
    if (!inst) return fmi2Error;
    return nvr == 0 ? fmi2OK : fail(inst, "%s: no such variable (value reference %u)", call, vr[0]);
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    (void)value;
    return no_variable(c, nvr, vr, "fmi2GetInteger");
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    (void)value;
    return no_variable(c, nvr, vr, "fmi2GetBoolean");
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    (void)value;
    return no_variable(c, nvr, vr, "fmi2GetString");
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    (void)value;
    return no_variable(c, nvr, vr, "fmi2SetInteger");
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    (void)value;
    return no_variable(c, nvr, vr, "fmi2SetBoolean");
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    (void)value;
    return no_variable(c, nvr, vr, "fmi2SetString");
}

/* ---- FMU state (FMI 2.0 section 2.1.8): not supported, canGetAndSetFMUstate = false ---- */

static fmi2Status unsupported(fmi2Component c, const char *call) {
    Instance *inst = c;
    return inst ? fail(inst, "%s is not supported by this FMU", call) : fmi2Error;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {
    (void)s;
    return unsupported(c, "fmi2GetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
    (void)s;
    return unsupported(c, "fmi2SetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) {
    (void)s;
    return unsupported(c, "fmi2FreeFMUstate");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    (void)s, (void)size;
    return unsupported(c, "fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte bytes[], size_t size) {
    (void)s, (void)bytes, (void)size;
    return unsupported(c, "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *s) {
    (void)bytes, (void)size, (void)s;
    return unsupported(c, "fmi2DeSerializeFMUstate");
}

/* ---- Derivatives (FMI 2.0 sections 2.1.9, 4.2.1): not provided ---- */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown[], size_t nUnknown,
                                        const fmi2ValueReference vKnown[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown, (void)nUnknown, (void)vKnown, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    return unsupported(c, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    return unsupported(c, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    return unsupported(c, "fmi2GetRealOutputDerivatives");
}

/* ---- Computation (FMI 2.0 section 4.2.2) ---- */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    Instance *inst = c;
    if (!inst) return fmi2Error;
    if (require(inst, IN(STEP_MODE), "fmi2DoStep") != fmi2OK) return fmi2Error;
    if (!(isfinite(communicationStepSize) && communicationStepSize > 0))
        return fail(inst, "fmi2DoStep: step size %g refused: must be finite and > 0", communicationStepSize);
    inst->time = currentCommunicationPoint + communicationStepSize;
    update_outputs(inst);
    return fmi2OK;
}

/* Steps are never asynchronous (no fmi2Pending), so there is nothing to cancel. */
fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, "fmi2CancelStep"); }

/* ---- Status (FMI 2.0 section 4.2.3): what is not available answers fmi2Discard ---- */

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s, (void)value;
    return c ? fmi2Discard : fmi2Error;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Instance *inst = c;
    if (!inst) return fmi2Error;
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = inst->time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s, (void)value;
    return c ? fmi2Discard : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    if (!c) return fmi2Error;
    if (s != fmi2Terminated) return fmi2Discard;
    *value = fmi2False; /* the FMU never asks to end the simulation */
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s, (void)value;
    return c ? fmi2Discard : fmi2Error;
}
