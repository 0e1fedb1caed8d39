"""The setting of the paper's section 4 that every component shares (Dien, Luy, Lai & Hai 2023): the
sampling period and the actuators' torque limit. Pure Python (no numpy), so that an FMU needing
only these, like the reference trajectory, asks its host for nothing."""

STEP_SIZE = 0.01  # s, the sampling period T: the master's communication step and each FMU's default
TORQUE_LIMIT = 4.0  # N.m, rho: the actuators bound the torque norm, ||tau|| <= rho (section 2.1; 4 in section 4)
