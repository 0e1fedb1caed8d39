/* A hostile controller FMU for the tests (FMI 2.0 Co-Simulation, plain C, outside our FMU framework):
 * the PD controller of examples/pd_controller, whose fmi2DoStep misbehaves from t = 1.00 s on in the
 * way HOSTILE_FAULT names (tests/support/hostile/__init__.py compiles one binary per fault):
 *
 *   1 SIGSEGV (a store through a null pointer)   2 an endless loop     3 NaN torques from then on
 *   4 fmi2Error with a logged message            5 exit(3)             6 abort()
 *
 * The example's code is included here whole, its fmi2DoStep renamed to pd_do_step, which the hostile
 * fmi2DoStep below calls before t = 1.00 s. */

#include <stdlib.h>

#include "fmi2Functions.h"

#undef fmi2DoStep
#define fmi2DoStep pd_do_step
#include "../../../examples/pd_controller/pd_controller.c"
#undef fmi2DoStep

#ifndef HOSTILE_FAULT
#error "compile with -DHOSTILE_FAULT=1..6 (the fault of fmi2DoStep)"
#endif

#ifndef FAULT_FROM
#define FAULT_FROM 0.995 /* the step from t = 1.00 s (sample 100 at T = 0.01 s) on; -DFAULT_FROM=... moves it */
#endif

#ifndef FAULT_KP_ABOVE
#define FAULT_KP_ABOVE -1.0 /* misbehave whatever the gain (Kp >= 0); -DFAULT_KP_ABOVE=... only above that Kp */
#endif

fmi2Status pd_do_step(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior);

FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Instance *inst = c;
    if (!inst || t < FAULT_FROM || !(inst->r[KP] > FAULT_KP_ABOVE)) return pd_do_step(c, t, h, noSetPrior);
#if HOSTILE_FAULT == 1
    volatile int *volatile nowhere = NULL; /* volatile: the compiler cannot know it is null, nor drop the store */
    *nowhere = 1;
#elif HOSTILE_FAULT == 2
    volatile int spinning = 1;
    while (spinning) {
    }
#elif HOSTILE_FAULT == 3
    inst->r[KP] = NAN; /* every torque computed from now on is NaN */
#elif HOSTILE_FAULT == 4
    return fail(inst, "fmi2DoStep: hostile fault at t = %.2f s", t);
#elif HOSTILE_FAULT == 5
    exit(3);
#elif HOSTILE_FAULT == 6
    abort();
#endif
    return pd_do_step(c, t, h, noSetPrior);
}
