"""The FMI 2.0 slave framework bundled into every sotc-cosim FMU: declared variables with units and
ranges, a modelDescription that validates, checked FMU states, and the workarounds pythonfmu 0.7
needs. It imports pythonfmu and the standard library only, never the models or the orchestration.
This file imports nothing, so the pure cores can use ``fmi_slave.parameters`` without pythonfmu."""

VERSION = "0.3.0"  # the project's version: pyproject.toml, the FMUs and the CLI read it here
