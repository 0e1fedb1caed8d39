"""The two-link arm, the reference trajectory and the perturbations: pure cores (numpy and the project's
numerics, no FMI) and their FMU scripts (FMI 2.0 and 3.0 co-simulation)."""
