# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for trajectory.py, which
# stays the one source of the formulas and runs as it is wherever the cores are not compiled. sin and cos
# are elementary.pxd's C functions; the circle's validation, with hypot, runs once.
cimport cython
from fmu_numerics.elementary cimport cos, hypot, sin
from fmu_plant.kinematics cimport inverse_kinematics, joint_rates

@cython.locals(a=double, s=double, c=double, r=double, w=double)
cpdef (double, double, double, double, double, double) circle_path(double t, double center_x, double center_y,
                                                                   double radius, double rate, double phase)
@cython.locals(x=double, y=double, dx=double, dy=double, ddx=double, ddy=double, phi1=double, phi2=double,
               dq1=double, dq2=double, ddq1=double, ddq2=double)
cpdef (double, double, double, double, double, double, double, double) circle_sample(
    double t, double center_x, double center_y, double radius, double rate, double phase, double l1, double l2)
