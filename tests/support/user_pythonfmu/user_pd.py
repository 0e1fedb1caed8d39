"""A PD controller for the two-link arm written as a user writes one with pythonfmu (nothing of this
project), under the controller contract's names (docs/benchmark.md)."""
from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Real

INPUTS = ("phi1", "phi2", "dphi1", "dphi2", "phi1_d", "phi2_d", "dphi1_d", "dphi2_d")


class UserPd(Fmi2Slave):
    author = "a user"
    description = "PD joint controller: tau = Kp (phi_d - phi) + Kd (dphi_d - dphi)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.Kp, self.Kd = 10.0, 3.0
        for name in INPUTS:
            setattr(self, name, 0.0)
        self.tau1 = self.tau2 = 0.0
        for name in ("Kp", "Kd"):
            self.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))
        for name in INPUTS:
            self.register_variable(Real(name, causality=Fmi2Causality.input))
        for name in ("tau1", "tau2"):
            self.register_variable(Real(name, causality=Fmi2Causality.output, initial=Fmi2Initial.exact))

    def do_step(self, current_time, step_size):
        self.tau1 = self.Kp * (self.phi1_d - self.phi1) + self.Kd * (self.dphi1_d - self.dphi1)
        self.tau2 = self.Kp * (self.phi2_d - self.phi2) + self.Kd * (self.dphi2_d - self.dphi2)
        return True
