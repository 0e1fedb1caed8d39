"""The two-link arm and the reference trajectory: pure numpy cores and their FMI 2.0 wrappers."""
