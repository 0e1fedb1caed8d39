"""Every built FMU passes fmpy's validation with zero problems."""
import pytest
from fmpy.validation import validate_fmu

from orchestration.fmu_build.build import FMU_SOURCES


@pytest.mark.parametrize("model", list(FMU_SOURCES))
def test_fmpy_validate_finds_no_problem(fmu_paths, model):
    assert validate_fmu(str(fmu_paths[model])) == []


@pytest.mark.parametrize("model", list(FMU_SOURCES))
def test_every_real_variable_has_a_unit_and_a_description(fmu_paths, model):
    from fmpy import read_model_description

    md = read_model_description(str(fmu_paths[model]))
    defined = {u.name for u in md.unitDefinitions}
    for v in md.modelVariables:
        assert v.description, v.name
        if v.type == "Real":
            assert v.unit in defined, v.name
    assert md.defaultExperiment.stepSize == "0.01" or float(md.defaultExperiment.stepSize) == 0.01
