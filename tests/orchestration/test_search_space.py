"""A controller file's search space (``[search]``, orchestration/run/search_space.py, docs/benchmark.md): its shape
refused by the JSON schema wherever a controller file is read, in one line naming the file and the key; what it
asks of the FMU checked against the modelDescription, a line per problem naming the key; and the dimensions the
tuning explores, float or int as the FMU's parameter is. The example of examples/pd_controller (FMI 2.0, Kp and
Kd declared min="0"), the same C as FMI 3.0 (tests/support/fmi3_pd) and the example with an Integer parameter."""
from __future__ import annotations

import zipfile
from pathlib import Path

import pytest
from support.example_controller import PORTS, built_fmu

from orchestration.compliance.contract import check, model_description, read_ports
from orchestration.run.scenario import ScenarioError, controller_instance
from orchestration.run.search_space import Dimension, dimensions, search_problems

LOG_GAINS = "Kp = { low = 1.0, high = 1000.0, log = true }\nKd = { low = 0.1, high = 200.0, log = true }\n"
IN_RANGE = "outside [0, inf], the range its modelDescription declares"


@pytest.fixture(scope="module")
def example(tmp_path_factory) -> Path:
    return built_fmu(tmp_path_factory.mktemp("pd"))


@pytest.fixture(scope="module")
def integer(example, tmp_path_factory) -> Path:
    """The example whose umax is an Integer in [1, 8] (a parameter a tool may well declare so: a count, a mode)."""
    edited = tmp_path_factory.mktemp("int") / "IntController.fmu"
    with zipfile.ZipFile(example) as src, zipfile.ZipFile(edited, "w") as out:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                data = data.replace(b'<Real unit="N.m" start="4.0"/>', b'<Integer min="1" max="8" start="4"/>')
                assert b"<Integer" in data
            out.writestr(item, data)
    return edited


def _file(folder: Path, fmu: Path, search: str, ports: dict | None = PORTS, parameters: str = "{ umax = 4.0 }") -> Path:
    """``folder/mine.toml``: a controller file as the issue writes one, with this ``[search]`` table."""
    text = f'fmu = "{fmu}"\n'
    if ports is not None:
        text += "ports = { " + ", ".join(f'{k} = "{v}"' for k, v in ports.items()) + " }\n"
    path = folder / "mine.toml"
    path.write_text(text + f"parameters = {parameters}\n[search]\n{search}")
    return path


def _problems(path: Path, fmu: Path) -> list[str]:
    """What ``check-controller --ports`` finds in the file, as ``contract.check`` reads it."""
    return check(fmu, *read_ports(path)).problems


def test_a_search_on_a_log_scale_gives_float_dimensions(example, tmp_path):
    path = _file(tmp_path, example, LOG_GAINS + "umax = { choices = [2.0, 4.0, 8.0] }\n", parameters="{}")
    assert _problems(path, example) == []
    assert dimensions(model_description(example), read_ports(path)[2]) == {
        "Kp": Dimension("Kp", "float", 1.0, 1000.0, True), "Kd": Dimension("Kd", "float", 0.1, 200.0, True),
        "umax": Dimension("umax", "choice", choices=(2.0, 4.0, 8.0))}
    # a scenario runs such a file with its fixed parameters: the search is read by the tuning
    controller = controller_instance(path, "mine.toml")
    assert controller.parameters == {} and controller.ports == PORTS


UNFED = {k: v for k, v in PORTS.items() if k not in ("dphi1_d", "dphi2_d")}  # the map: dq1_ref is fed by none


@pytest.mark.parametrize("search, ports, problems", [
    ("Kq = { low = 1.0, high = 2.0 }\n", PORTS, ["search.Kq: the FMU has no variable 'Kq'; near: Kp, Kd"]),
    ("nope = { low = 1.0, high = 2.0 }\n", PORTS, ["search.nope: the FMU has no variable 'nope'"]),
    ("dq1_ref = { low = 1.0, high = 2.0 }\n", UNFED, [
        "search.dq1_ref: causality 'input', variability 'continuous': not a parameter a host may set (a fixed or "
        "tunable parameter)"]),
    ("u1 = { low = 1.0, high = 2.0 }\n", PORTS, [
        "search.u1: a port (ports.tau1 = 'u1'): a search tunes parameters, not what the controller reads or writes"]),
    ("q1 = { choices = [0.0, 1.0] }\n", PORTS, [
        "search.q1: a port (ports.phi1 = 'q1'): a search tunes parameters, not what the controller reads or writes"]),
    ("Kp = { low = 10.0, high = 1.0 }\n", PORTS, ["search.Kp: low = 10, high = 1: an empty or reversed range (low < high)"]),
    ("Kp = { low = 5.0, high = 5.0 }\n", PORTS, ["search.Kp: low = 5, high = 5: an empty or reversed range (low < high)"]),
    ("Kd = { low = 0.0, high = 1.0, log = true }\n", PORTS, ["search.Kd.low = 0: a log scale needs low > 0"]),
    ("Kp = { low = -1.0, high = 10.0 }\n", PORTS, [f"search.Kp.low = -1: {IN_RANGE}"]),
    ("Kd = { choices = [2.0, -0.5] }\n", PORTS, [f"search.Kd.choices[1] = -0.5: {IN_RANGE}"]),
    ("umax = { low = 1.0, high = 8.0 }\n", PORTS, [
        "search.umax: also fixed in parameters (umax = 4): a parameter is searched or fixed, not both"]),
], ids=["an unknown parameter", "nothing near", "an input", "an output mapped", "an input mapped", "reversed",
        "low = high", "log from 0", "below the declared min", "a choice below the declared min", "also fixed"])
def test_a_search_the_fmu_cannot_take_is_a_line_naming_the_key(example, tmp_path, search, ports, problems):
    assert _problems(_file(tmp_path, example, search, ports), example) == problems


def test_every_problem_of_a_file_is_named(example, tmp_path):
    """One line per problem, in the table's order, a valid entry among them saying nothing."""
    path = _file(tmp_path, example, "Kp = { low = -1.0, high = -2.0, log = true }\nKd = { low = 1.0, high = 2.0 }\n"
                 "umax = { choices = [1.0, 2.0] }\n")
    assert _problems(path, example) == [
        "search.Kp: low = -1, high = -2: an empty or reversed range (low < high)",
        "search.Kp.low = -1: a log scale needs low > 0",
        f"search.Kp.low = -1: {IN_RANGE}", f"search.Kp.high = -2: {IN_RANGE}",
        "search.umax: also fixed in parameters (umax = 4): a parameter is searched or fixed, not both"]


@pytest.mark.parametrize("search, said", [
    ("Kp = { low = 1.0, high = inf }\n", "search.Kp.high: inf is not finite"),
    ("Kp = { low = nan, high = 1.0 }\n", "search.Kp.low: nan is not finite"),
    ("Kp = { low = 1.0, high = 2.0, step = 0.5 }\n", "search.Kp: unknown keys ['step']; known: ['high', 'log', 'low']"),
    ("Kp = { choices = [1.0, 2.0], log = true }\n", "search.Kp: unknown keys ['log']; known: ['choices']"),
    ("Kp = { choices = [60.0] }\n", "search.Kp.choices: [60.0]: at least 2 values"),
    ("Kp = { choices = [60.0, 60] }\n", "search.Kp.choices: [60.0, 60]: each value once"),
    ("Kp = { choices = [60.0, -inf] }\n", "search.Kp.choices[1]: -inf is not finite"),
    ("Kp = { low = 1.0 }\n", "search.Kp: 'high' is a required property"),
    ("Kp = { low = 1.0, high = 2.0, log = 1 }\n", "search.Kp.log: 1 is not true or false"),
    ("Kp = 60.0\n", "search.Kp: 60.0 is not a table"),
], ids=["inf", "nan", "an unknown key", "log on a choice", "one choice", "a choice twice", "a choice not finite",
        "no high", "log not a boolean", "not a table"])
def test_a_search_of_the_wrong_shape_is_one_line_naming_the_file_and_the_key(example, tmp_path, search, said):
    """As a scenario or a sweep reads a controller file (which then runs its fixed parameters), and as
    check-controller reads one given as --ports."""
    path = _file(tmp_path, example, search)
    with pytest.raises(ScenarioError) as found:
        controller_instance(path, "mine.toml")
    assert str(found.value) == f"mine.toml: {said}"
    with pytest.raises(ValueError) as found:
        read_ports(path)
    assert str(found.value) == f"{path}: {said}"


def test_an_fmi3_search_without_a_map_refuses_the_contracts_names(tmp_path):
    """The FMI 3.0 controller uses the contract's own names (no map): those it has are its ports."""
    from support import fmi3_pd

    fmu = fmi3_pd.build(tmp_path)
    path = _file(tmp_path, fmu, LOG_GAINS, ports=None, parameters="{}")
    assert _problems(path, fmu) == []
    assert dimensions(model_description(fmu), read_ports(path)[2]) == {
        "Kp": Dimension("Kp", "float", 1.0, 1000.0, True), "Kd": Dimension("Kd", "float", 0.1, 200.0, True)}
    bad = "tau1 = { low = 0.0, high = 1.0 }\nphi1 = { low = 0.0, high = 1.0 }\ntime = { low = 0.0, high = 1.0 }\n"
    assert _problems(_file(tmp_path, fmu, bad, ports=None, parameters="{}"), fmu) == [
        "search.tau1: a port (the contract's tau1): a search tunes parameters, not what the controller reads or writes",
        "search.phi1: a port (the contract's phi1): a search tunes parameters, not what the controller reads or writes",
        "search.time: causality 'independent', variability 'continuous': not a parameter a host may set (a fixed or "
        "tunable parameter)"]


def test_an_integer_parameter_is_searched_in_whole_numbers(integer, tmp_path):
    md = model_description(integer)
    table = {"umax": {"low": 1.0, "high": 8.0, "log": True}}
    assert search_problems(md, table, PORTS, {}) == []
    found = dimensions(md, table)["umax"]
    assert found == Dimension("umax", "int", 1, 8, True) and type(found.low) is type(found.high) is int
    assert dimensions(md, {"umax": {"choices": [2, 4.0]}})["umax"] == Dimension("umax", "choice", choices=(2, 4))
    assert search_problems(md, {"umax": {"low": 1.5, "high": 9.0}}, PORTS, {}) == [
        "search.umax.low = 1.5: umax is an integer (Integer)",
        "search.umax.high = 9: outside [1, 8], the range its modelDescription declares"]
    assert search_problems(md, {"umax": {"choices": [2.0, 4.5]}}, PORTS, {}) == [
        "search.umax.choices[1] = 4.5: umax is an integer (Integer)"]
