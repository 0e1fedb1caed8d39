# Declarations for the compiled cores (orchestration/fmu_build/compiled.py): C types for dynamics.py, which
# stays the one source of the formulas and runs as it is wherever the cores are not compiled. ``math`` is
# libc's here (sqrt, ceil, isfinite: exact or correctly rounded); cos, sin, sincos, tanh and hypot are
# elementary.pxd's.
cimport cython
from libc cimport math
from fmu_numerics.elementary cimport cos, hypot, sin, sincos, tanh

ctypedef (double, double, double, double, double, double, double) coef_t  # ArmParameters.coefficients

cpdef (double, double, double) inertia_entries(double phi2, object p)
cpdef (double, double, double) coriolis_entries(double phi2, double dphi1, double dphi2, object p)
cpdef (double, double) friction_torque(double dphi1, double dphi2, object p)
cpdef (double, double) bias_torque(double phi2, double dphi1, double dphi2, object p)
cpdef (double, double) solve_inertia(double phi2, double r1, double r2, object p)
cpdef (double, double) forward_dynamics(double phi2, double dphi1, double dphi2, double tau1, double tau2, object p)

cdef (double, double, double) _inertia(double c2, coef_t k) noexcept
@cython.locals(s=double)
cdef (double, double, double) _coriolis(double s2, double dphi1, double dphi2, coef_t k) noexcept
cdef (double, double) _friction(double dphi1, double dphi2, coef_t k) noexcept
@cython.locals(h11=double, h12=double, h21=double, g1=double, g2=double)
cdef (double, double) _bias(double s2, double dphi1, double dphi2, coef_t k) noexcept
@cython.locals(d11=double, d12=double, d22=double, det=double)
cdef (double, double) _solve_inertia(double c2, double r1, double r2, coef_t k)
@cython.locals(s2=double, c2=double, b1=double, b2=double)
cdef (double, double) _accel(double phi2, double dphi1, double dphi2, double tau1, double tau2, coef_t k)

@cython.locals(d11=double, d12=double, d22=double, c1=double, c2=double)
cpdef (double, double) inverse_dynamics(double phi2, double dphi1, double dphi2, double ddphi1, double ddphi2, object p)
@cython.locals(c=coef_t, p3=double, k=double, w=double, friction=double, damping=double, bias=double,
               position=double, n=double)
cpdef int substeps_needed(double phi2, double dphi1, double dphi2, double dt, object p, double tau_norm=*)
@cython.locals(d11=double, d12=double, d22=double)
cpdef double kinetic_energy(double phi2, double dphi1, double dphi2, object p)
@cython.locals(q1=double, q2=double, w1=double, w2=double, tau_norm=double, n=int, speed_before=double,
               speed_after=double, allowed=double)
cpdef tuple integrate(tuple state, double tau1, double tau2, double dt, int min_substeps, object p)
@cython.locals(q1=double, q2=double, w1=double, w2=double, h=double, half=double, sixth=double, k=coef_t,
               a1=double, a2=double, b1=double, b2=double, c1=double, c2=double, e1=double, e2=double,
               k2q2=double, k2w1=double, k2w2=double, k3q2=double, k3w1=double, k3w2=double,
               k4q2=double, k4w1=double, k4w2=double)
cpdef tuple rk4_step(tuple state, double tau1, double tau2, double dt, int substeps, object p)
