# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for kinematics.py, which
# stays the one source of the formulas and runs as it is wherever the cores are not compiled. sin, sincos,
# acos and atan2 are elementary.pxd's C functions.
cimport cython
from fmu_numerics.elementary cimport acos, atan2, sin, sincos

@cython.locals(s1=double, c1=double, sa=double, ca=double, ex=double, ey=double)
cpdef (double, double, double, double) arm_points(double phi1, double phi2, double l1, double l2)
@cython.locals(c2=double, sin2=double, cos2=double, phi1=double, phi2=double)
cpdef (double, double) inverse_kinematics(double x, double y, double l1, double l2)
@cython.locals(s1=double, c1=double, sa=double, ca=double)
cpdef (double, double, double, double) jacobian(double phi1, double phi2, double l1, double l2)
cpdef (double, double, double, double) jacobian_of(double s1, double c1, double sa, double ca, double l1, double l2) noexcept
@cython.locals(j11=double, j12=double, j21=double, j22=double, det=double, dq1=double, dq2=double,
               s1=double, c1=double, sa=double, ca=double, da=double, jd1=double, jd2=double, rx=double, ry=double,
               ddq1=double, ddq2=double)
cpdef (double, double, double, double) joint_rates(double phi1, double phi2, double dx, double dy, double ddx,
                                                   double ddy, double l1, double l2)
