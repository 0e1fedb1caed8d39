# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc.py, which
# stays the one source of the formulas and runs as it is wherever the cores are not compiled. ``math`` is
# libc's here (sqrt, isfinite); fsum and nan are Python's, imported by name; hypot and tanh elementary.pxd's.
from libc cimport math
from fmu_controller.elementary cimport hypot, tanh
from fmu_controller.saturation cimport clip_box, limit_torque, limit_without_metric, saturate_norm
from fmu_controller.fixed_linalg cimport add_scaled, cholesky, cholesky_solve, dot, scale_into
from fmu_controller.sotc_math cimport (basis, critic_row, directional_into, gradient, implicit_system, normalisation,
                                       policy_arguments, probing_signal)
from fmu_controller.sotc_zv cimport solve_zv
from fmu_plant.dynamics cimport bias_torque, forward_dynamics, inertia_entries
