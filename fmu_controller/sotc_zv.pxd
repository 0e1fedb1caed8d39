# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for sotc_zv.py, which
# stays the one source of the formulas and runs as it is wherever the cores are not compiled. tanh and atanh are
# elementary.pxd's C functions, ``math`` is libc's (sqrt, isfinite). The guess-free bisection (``solve_tanh_system``,
# a rare fallback with closures) stays Python code, compiled as such.
cimport cython
from libc cimport math
from fmu_numerics.elementary cimport atanh, tanh
from fmu_controller.sotc_math cimport CriticConstants, gradient

@cython.locals(s=double, g1=double, g2=double, t1=double, t2=double)
cpdef (double, double, double, double) zv_residual(CriticConstants K, double zp1, double zp2, double zv1, double zv2,
                                                   double c1, double c2, double a1, double a2, double[::1] W)
@cython.locals(r1=double, r2=double, t1=double, t2=double, f1=double, f2=double, n2=double,
               k1=double, k2=double, j11=double, j12=double, j21=double, j22=double, det=double, d1=double, d2=double,
               tiny=bint, step=double, y1=double, y2=double, u1=double, u2=double, e1=double, e2=double, m2=double)
cpdef (double, double, double, double) newton_zv(CriticConstants K, double zp1, double zp2, double c1, double c2,
                                                 double a1, double a2, double[::1] W, double h13, double h14,
                                                 double h23, double h24, double zv1, double zv2, bint damped)
@cython.locals(s=double, r1=double, r2=double, f1=double, f2=double, res=double, tol=double, y1=double, y2=double,
               e1=double, e2=double, g1=double, g2=double, t1=double, t2=double)
cpdef (double, double, double) solve_zv(CriticConstants K, double zp1, double zp2, double c1, double c2, double a1,
                                        double a2, double[::1] W, double h13, double h14, double h23, double h24)
