# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc.py, which
# stays the one source of the formulas and runs as it is wherever the cores are not compiled.
from fmu_controller.saturation cimport clip_box, limit_torque, limit_without_metric, saturate_norm
from fmu_controller.fixed_linalg cimport cholesky, cholesky_solve
from fmu_controller.sotc_math cimport (basis, basis_directional, dot_sequence, error_rate, implicit_system,
                                       policy_arguments, printed_rate, probing_signal, reward, value_gradient)
from fmu_controller.sotc_zv cimport solve_zv
from fmu_plant.dynamics cimport bias_torque, forward_dynamics, inertia_entries
