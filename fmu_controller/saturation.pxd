# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for saturation.py, which
# stays the one source of the formulas and runs as it is wherever the cores are not compiled. ``math`` stays
# Python's here (inf, and the rare paths' sqrt, ldexp, isfinite); the exact test in_disc falls back to
# (Python integers) is a Python function.
cimport cython
from fmu_numerics.elementary cimport atan2, cos, hypot, sin

@cython.locals(c1=double, c2=double)
cpdef (double, double, bint) clip_box(double v1, double v2, double bound) noexcept
cpdef bint _in_disc(double v1, double v2, double bound, double h) except -1
@cython.locals(k=double, i=int)
cpdef (double, double) shrink_into_disc(double v1, double v2, double bound)
@cython.locals(norm=double, k=double, s1=double, s2=double)
cpdef (double, double, double, bint) saturate_norm(double v1, double v2, double bound)
@cython.locals(c1=double, c2=double, changed=bint)
cpdef (double, double, bint) limit_without_metric(double v1, double v2, double bound, int code)
@cython.locals(n=double, half_tr=double, half_diff=double, rad=double, da=double, db=double, ang=double, c=double,
               s=double, qa=double, qb=double, aa=double, ab=double, hi=double, lo=double, mid=double, fa=double,
               fb=double, s1=double, s2=double)
cpdef (double, double, bint) accel_projection(double t1, double t2, double bound, double d11, double d12, double d22)
@cython.locals(c1=double, c2=double, changed=bint, b1=double, b2=double, boxed=bint, capped=bint)
cpdef (double, double, bint) limit_torque(int code, double t1, double t2, double bound, double d11, double d12,
                                         double d22)
