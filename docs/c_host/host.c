/*
 * A minimal FMI 2.0 co-simulation host in C, without Python: it loads the ArmPlant FMU's shared
 * library from an extracted FMU, instantiates it with a small logger, sets the joint torques,
 * steps it and prints the joint angles after every step, one line "t phi1 phi2" (17 digits).
 *
 *   gcc -O2 -o host host.c -ldl
 *   ./host UNZIPDIR GUID VR_TAU1 VR_TAU2 VR_PHI1 VR_PHI2 TAU1 TAU2 STEPS
 *
 * The value references come from modelDescription.xml (the test passes them). A pythonfmu binary
 * does not link libpython: its Python symbols must already be in the process, e.g.
 *   LD_PRELOAD=/path/to/libpython3.11.so.1.0 ./host ...
 * (see docs/interop.md, "A non-Python host"). Without them dlopen fails and this host says why.
 *
 * Nothing here is specific to pythonfmu: the host frees the instance and returns from main. Our FMUs
 * settle pythonfmu 0.7.0's exit-time use-after-free themselves; for other pythonfmu 0.7.0 FMUs a host
 * calls the binary's finalizePythonInterpreter() after the last fmi2FreeInstance (same section).
 *
 * Only the FMI 2.0 types this host uses are declared here, as the standard defines them.
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef const char *fmi2String;
typedef double fmi2Real;
typedef int fmi2Boolean;
typedef unsigned int fmi2ValueReference;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;

typedef struct {
    void (*logger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef fmi2Component (*Instantiate)(fmi2String, fmi2Type, fmi2String, fmi2String,
                                     const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean);
typedef fmi2Status (*SetupExperiment)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real);
typedef fmi2Status (*Simple)(fmi2Component);
typedef fmi2Status (*SetReal)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Real[]);
typedef fmi2Status (*GetReal)(fmi2Component, const fmi2ValueReference[], size_t, fmi2Real[]);
typedef fmi2Status (*DoStep)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
typedef void (*FreeInstance)(fmi2Component);

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    va_list args;
    (void)env;
    fprintf(stderr, "[%s status=%d %s] ", instance ? instance : "", (int)status, category ? category : "");
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

static void *symbol(void *lib, const char *name) {
    void *f = dlsym(lib, name);
    if (!f) {
        fprintf(stderr, "host: missing FMI function %s: %s\n", name, dlerror());
        exit(3);
    }
    return f;
}

#define CHECK(call, what)                                                   \
    do {                                                                    \
        fmi2Status s_ = (call);                                             \
        if (s_ != fmi2OK) {                                                 \
            fprintf(stderr, "host: %s returned status %d\n", what, (int)s_); \
            return 4;                                                       \
        }                                                                   \
    } while (0)

int main(int argc, char **argv) {
    if (argc != 10) {
        fprintf(stderr, "usage: %s UNZIPDIR GUID VR_TAU1 VR_TAU2 VR_PHI1 VR_PHI2 TAU1 TAU2 STEPS\n", argv[0]);
        return 1;
    }
    const char *dir = argv[1], *guid = argv[2];
    fmi2ValueReference tau_vr[2] = {(fmi2ValueReference)atoi(argv[3]), (fmi2ValueReference)atoi(argv[4])};
    fmi2ValueReference phi_vr[2] = {(fmi2ValueReference)atoi(argv[5]), (fmi2ValueReference)atoi(argv[6])};
    fmi2Real tau[2] = {atof(argv[7]), atof(argv[8])};
    int steps = atoi(argv[9]);
    const fmi2Real h = 0.01;

    char library[4096], resources[4096];
    snprintf(library, sizeof library, "%s/binaries/linux64/ArmPlant.so", dir);
    snprintf(resources, sizeof resources, "file://%s/resources", dir);

    void *lib = dlopen(library, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "host: cannot load %s: %s\n", library, dlerror());
        return 2;
    }
    Instantiate instantiate = (Instantiate)symbol(lib, "fmi2Instantiate");
    SetupExperiment setup = (SetupExperiment)symbol(lib, "fmi2SetupExperiment");
    Simple enter = (Simple)symbol(lib, "fmi2EnterInitializationMode");
    Simple leave = (Simple)symbol(lib, "fmi2ExitInitializationMode");
    Simple terminate = (Simple)symbol(lib, "fmi2Terminate");
    SetReal set_real = (SetReal)symbol(lib, "fmi2SetReal");
    GetReal get_real = (GetReal)symbol(lib, "fmi2GetReal");
    DoStep do_step = (DoStep)symbol(lib, "fmi2DoStep");
    FreeInstance free_instance = (FreeInstance)symbol(lib, "fmi2FreeInstance");

    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2Component c = instantiate("plant", fmi2CoSimulation, guid, resources, &callbacks, 0, 1);
    if (!c) {
        fprintf(stderr, "host: fmi2Instantiate failed\n");
        return 4;
    }
    CHECK(setup(c, 0, 0.0, 0.0, 0, 0.0), "fmi2SetupExperiment");
    CHECK(enter(c), "fmi2EnterInitializationMode");
    CHECK(leave(c), "fmi2ExitInitializationMode");
    CHECK(set_real(c, tau_vr, 2, tau), "fmi2SetReal");
    fmi2Real phi[2];
    for (int k = 0; k < steps; ++k) {
        CHECK(do_step(c, k * h, h, 1), "fmi2DoStep");
        CHECK(get_real(c, phi_vr, 2, phi), "fmi2GetReal");
        printf("%.17g %.17g %.17g\n", (k + 1) * h, phi[0], phi[1]);
    }
    CHECK(terminate(c), "fmi2Terminate");
    free_instance(c);
    fflush(stdout);
    return 0;
}
