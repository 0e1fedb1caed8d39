# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc.py, which
# stays the one source of the SOTC core's parameters and state and runs as it is wherever the cores are not
# compiled. Its sample is SotcKernel's (sotc_kernel.pxd, an extension type); tanh is elementary.pxd's.
from fmu_numerics.elementary cimport tanh
from fmu_controller.sotc_math cimport policy_arguments
