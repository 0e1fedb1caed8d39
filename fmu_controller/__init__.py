"""Controller cores (pure numpy) and their FMI 2.0 co-simulation wrappers."""
