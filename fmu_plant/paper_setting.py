"""The setting of the paper's section 4 that every component shares (Dien, Luy, Lai & Hai 2023): the
sampling period, the actuators' torque limit, the initial state and the plant's RK4 substeps. Pure Python (no numpy), so that an FMU needing
only these, like the reference trajectory, asks its host for nothing."""

STEP_SIZE = 0.01  # s, the sampling period T: the master's communication step and each FMU's default
TORQUE_LIMIT = 4.0  # N.m, rho: the actuators bound the torque norm, ||tau|| <= rho (section 2.1; 4 in section 4)
INITIAL_ANGLES = (0.5, -0.5)  # rad, phi(0) of section 4
INITIAL_VELOCITIES = (0.0, 0.0)  # rad/s, dphi(0) of section 4
INITIAL_STATE = (*INITIAL_ANGLES, *INITIAL_VELOCITIES)  # (phi1, phi2, dphi1, dphi2) at t = 0
SUBSTEPS = 4  # RK4 substeps per period T at least (the plant FMU's default ``substeps``; dynamics.integrate)
