"""The FMI 2.0 co-simulation states a ``DescribedSlave`` moves through (its ``_mode``)."""

INSTANTIATED = "instantiated"
INITIALIZATION = "initialization mode"
STEPPING = "stepping"
TERMINATED = "terminated"
