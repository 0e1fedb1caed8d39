"""The test suite's direct FMI driver: ``orchestration.run.fmi_direct.FmuInstance`` with the
(file, unzip folder, instance name) signature the tests use."""
from __future__ import annotations

from pathlib import Path

from orchestration.run.fmi_direct import FmuInstance


class DrivenFmu(FmuInstance):
    """One instance of an FMU extracted to ``unzipdir``, its log messages in ``messages``."""

    def __init__(self, fmu_file: Path, unzipdir: Path, instance_name: str = "instance"):
        super().__init__(fmu_file, instance_name, workdir=unzipdir)
        self.vr = {name: v.valueReference for name, v in self.vars.items()}
