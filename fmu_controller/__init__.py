"""The controllers: pure cores (numpy and the project's numerics, no FMI), the controller catalog, and
their FMU scripts (FMI 2.0 and 3.0 co-simulation)."""
