"""The port convention every controller FMU shares, and the controller contract names a controller FMU from
any tool is held to (docs/benchmark.md): inputs are named exactly like the outputs that feed them. No
imports: the command line reads these before it loads numpy."""

MEASUREMENT_PORTS = ("phi1", "phi2", "dphi1", "dphi2")
REFERENCE_PORTS = ("phi1_d", "phi2_d", "dphi1_d", "dphi2_d", "ddphi1_d", "ddphi2_d")
TORQUE_PORTS = ("tau1", "tau2")
TORQUE_UNIT = "N.m"
INPUT_UNITS = {
    "phi1": "rad", "phi2": "rad", "dphi1": "rad/s", "dphi2": "rad/s",
    "phi1_d": "rad", "phi2_d": "rad", "dphi1_d": "rad/s", "dphi2_d": "rad/s",
    "ddphi1_d": "rad/s2", "ddphi2_d": "rad/s2",
}
# every name a port map may map: what a controller reads, then what it writes (docs/benchmark.md)
CONTRACT_NAMES = (*INPUT_UNITS, *TORQUE_PORTS)
