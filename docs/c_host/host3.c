/*
 * A minimal FMI 3.0 co-simulation host in C, without Python: it loads the FMI 3 ArmPlant's shared
 * library from an extracted FMU, instantiates it with a small logger, sets the torque array, steps it
 * and prints the joint angle array after every step, one line "t phi1 phi2" (17 digits). Before the
 * first step it sets the torque with 3 values and reads the angles with 1, and prints each status
 * ("size set STATUS", "size get STATUS"): the FMU answers both with fmi3Error and goes on.
 *
 *   gcc -O2 -I FMI3_HEADERS -o host3 host3.c -ldl
 *   ./host3 UNZIPDIR INSTANTIATION_TOKEN VR_TAU VR_PHI TAU1 TAU2 STEPS
 *
 * FMI3_HEADERS: the FMI 3.0 standard's headers (fmi3FunctionTypes.h), e.g. the folder
 * pythonfmu-export/src/fmi of an installed pythonfmu3. The value references come from
 * modelDescription.xml (the test passes them). As for host.c, the Python symbols must already be in
 * the process (LD_PRELOAD of libpython; docs/interop.md, "A non-Python host").
 */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi3FunctionTypes.h"

static void logger(fmi3InstanceEnvironment environment, fmi3Status status, fmi3String category,
                   fmi3String message) {
    (void) environment;
    fprintf(stderr, "[%d] %s: %s\n", (int) status, category ? category : "", message ? message : "");
}

#define LOOKUP(name)                                                                                   \
    fmi3##name##TYPE *name = (fmi3##name##TYPE *) dlsym(library, "fmi3" #name);                         \
    if (!name) {                                                                                       \
        fprintf(stderr, "fmi3" #name " is not exported\n");                                            \
        return 2;                                                                                      \
    }

int main(int argc, char **argv) {
    char path[4096], resources[4096];
    if (argc != 8) {
        fprintf(stderr, "usage: %s UNZIPDIR TOKEN VR_TAU VR_PHI TAU1 TAU2 STEPS\n", argv[0]);
        return 2;
    }
    snprintf(path, sizeof path, "%s/binaries/x86_64-linux/ArmPlant.so", argv[1]);
    snprintf(resources, sizeof resources, "%s/resources/", argv[1]);
    void *library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!library) {
        fprintf(stderr, "cannot load %s: %s\n", path, dlerror());
        return 2;
    }
    LOOKUP(InstantiateCoSimulation) LOOKUP(EnterInitializationMode) LOOKUP(ExitInitializationMode)
    LOOKUP(SetFloat64) LOOKUP(GetFloat64) LOOKUP(DoStep) LOOKUP(Terminate) LOOKUP(FreeInstance)
    fmi3ValueReference tau = (fmi3ValueReference) atoi(argv[3]), phi = (fmi3ValueReference) atoi(argv[4]);
    fmi3Float64 torque[3] = {atof(argv[5]), atof(argv[6]), 0.0}, angles[3], last;
    fmi3Boolean event, stop, early;
    int steps = atoi(argv[7]);
    fmi3Instance instance = InstantiateCoSimulation("host3", argv[2], resources, fmi3False, fmi3True, fmi3False,
                                                    fmi3False, NULL, 0, NULL, logger, NULL);
    if (!instance) {
        fprintf(stderr, "fmi3InstantiateCoSimulation failed\n");
        return 1;
    }
    if (EnterInitializationMode(instance, fmi3False, 0.0, 0.0, fmi3False, 0.0) != fmi3OK
        || ExitInitializationMode(instance) != fmi3OK) return 1;
    printf("size set %d\n", (int) SetFloat64(instance, &tau, 1, torque, 3));
    printf("size get %d\n", (int) GetFloat64(instance, &phi, 1, angles, 1));
    if (SetFloat64(instance, &tau, 1, torque, 2) != fmi3OK) return 1;
    for (int k = 0; k < steps; k++) {
        if (DoStep(instance, k * 0.01, 0.01, fmi3True, &event, &stop, &early, &last) != fmi3OK
            || GetFloat64(instance, &phi, 1, angles, 2) != fmi3OK) return 1;
        printf("%.17g %.17g %.17g\n", (k + 1) * 0.01, angles[0], angles[1]);
    }
    Terminate(instance);
    FreeInstance(instance);
    dlclose(library);
    return 0;
}
