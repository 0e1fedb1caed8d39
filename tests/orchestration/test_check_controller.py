"""``sotc-cosim check-controller``: a controller FMU from another tool against the controller contract
(orchestration/compliance/contract.py, docs/benchmark.md), through the installed console script: the C example
of examples/pd_controller with its port map, our own controllers without one, and FMUs and maps that break the
contract, each named in one line; then its 1 s run against our arm (orchestration/compliance/smoke.py)."""
from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import fmpy
import pytest
from support.example_controller import PORTS, built_fmu

from orchestration.compliance.contract import UNITS

CLI = str(Path(sys.executable).with_name("sotc-cosim"))


def _check(fmu: Path, cwd: Path, ports: dict | str | None = None) -> subprocess.CompletedProcess:
    """The interface checks only (``--no-run``); the 1 s run against our arm is tested below."""
    args = [CLI, "check-controller", str(fmu), "--no-run"]
    if ports is not None:
        text = ports if isinstance(ports, str) else "ports = { " + ", ".join(f'{k} = "{v}"' for k, v in ports.items()) + " }\n"
        (cwd / "ports.toml").write_text(text)
        args += ["--ports", "ports.toml"]
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def example(tmp_path_factory) -> Path:
    return built_fmu(tmp_path_factory.mktemp("pd"))


def test_the_example_meets_the_contract_through_its_port_map(example, tmp_path):
    done = _check(example, tmp_path, PORTS)
    assert done.returncode == 0, done.stdout + done.stderr
    assert all(f"{k:9s} -> {v}" in done.stdout for k, v in PORTS.items()) and "meets the controller contract" in done.stdout


def test_without_a_map_the_examples_own_names_are_no_torques(example, tmp_path):
    done = _check(example, tmp_path)
    assert done.returncode == 1
    problems = [line for line in done.stdout.splitlines() if "problem:" in line]
    assert problems == [f"  problem: ports.{k} = '{k}': the FMU has no variable '{k}' (an array's element: name[i], "
                        "from 1)" for k in ("tau1", "tau2")], done.stdout
    assert "(left at their start values): q1, q2, dq1, dq2, q1_ref, q2_ref, dq1_ref, dq2_ref" in done.stdout


@pytest.mark.parametrize("change, problem", [
    ({"phi1": "u1"}, "ports.phi1 = 'u1': causality 'output', the contract needs an input"),
    ({"phi1": "u1"}, "ports.phi1 = 'u1': unit 'N.m', the contract's is 'rad'"),
    ({"tau2": "Kp"}, "ports.tau2 = 'Kp': causality 'parameter', the contract needs an output"),
    ({"dphi1": "nope"}, "ports.dphi1 = 'nope': the FMU has no variable 'nope'"),
    ({"tau1": "u1[1]"}, "ports.tau1 = 'u1[1]': the FMU has no variable 'u1[1]'"),
], ids=["an output read", "a unit", "a parameter written", "no such variable", "no such array"])
def test_a_map_that_breaks_the_contract_is_named_by_its_key(example, tmp_path, change, problem):
    done = _check(example, tmp_path, {**PORTS, **change})
    assert done.returncode == 1 and problem in done.stdout, done.stdout


def _with_parameters(parameters: str) -> str:
    return "ports = { " + ", ".join(f'{k} = "{v}"' for k, v in PORTS.items()) + " }\nparameters = " + parameters + "\n"


def test_the_parameters_to_set_are_checked_against_the_fmus(example, tmp_path):
    """Kp = 30 can be set; Kd below the min its modelDescription declares, a variable it lacks and an input cannot."""
    done = _check(example, tmp_path, _with_parameters("{ Kp = 30.0, Kd = -1.0, nope = 1, q1 = 0.5 }"))
    assert done.returncode == 1 and "  parameter Kp = 30" in done.stdout, done.stdout
    problems = [line.removeprefix("  problem: ") for line in done.stdout.splitlines() if "problem:" in line]
    assert problems == ["parameters.Kd = -1: outside [0, inf], the range its modelDescription declares",
                        "parameters.nope = 1: the FMU has no variable 'nope'",
                        "parameters.q1 = 0.5: causality 'input', variability 'continuous': not a parameter a host may "
                        "set (a fixed or tunable parameter)"], done.stdout
    assert _check(example, tmp_path, _with_parameters("{ Kp = 30.0, umax = 3 }")).returncode == 0


def test_a_controller_files_search_is_checked_against_the_fmu(example, tmp_path):
    """A controller file given as --ports: its [search] said back, and each value the FMU cannot take a problem
    naming its key (tests/orchestration/test_search_space.py has every kind)."""
    search = "[search]\nKp = { low = 1.0, high = 1000.0, log = true }\nKd = { choices = [5.0, 20.0] }\n"
    done = _check(example, tmp_path, _with_parameters("{ umax = 4.0 }") + search)
    assert done.returncode == 0, done.stdout
    assert "  search Kp in [1, 1000], log scale\n  search Kd among 5, 20\n" in done.stdout
    done = _check(example, tmp_path, _with_parameters("{ umax = 4.0 }") + search.replace("5.0", "-5.0") + "u1 = "
                  "{ low = 0.0, high = 1.0 }\n")
    problems = [line.removeprefix("  problem: ") for line in done.stdout.splitlines() if "problem:" in line]
    assert done.returncode == 1 and problems == [
        "search.Kd.choices[0] = -5: outside [0, inf], the range its modelDescription declares",
        "search.u1: a port (ports.tau1 = 'u1'): a search tunes parameters, not what the controller reads or writes"], \
        done.stdout


def test_a_parameter_of_a_type_a_run_cannot_set_is_a_problem(example, tmp_path):
    """The check holds a parameter to what the master's runs set (parameter_check.SETTABLE_TYPES): a Boolean Kp
    passed the check and then refused every run."""
    edited = tmp_path / "bool.fmu"
    with zipfile.ZipFile(example) as src, zipfile.ZipFile(edited, "w") as out:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                data = data.replace(b'<Real unit="N.m/rad" min="0" start="60.0"/>', b'<Boolean start="true"/>')
                assert b"<Boolean" in data
            out.writestr(item, data)
    done = _check(edited, tmp_path, _with_parameters("{ Kp = 1 }"))
    assert done.returncode == 1, done.stdout
    assert "parameters.Kp = 1: type Boolean: a run sets parameters of type Real, Integer, Float64, Int32 only" in done.stdout


def test_a_map_without_both_torques_is_refused(example, tmp_path):
    done = _check(example, tmp_path, {k: v for k, v in PORTS.items() if k != "tau2"})
    assert done.returncode == 1 and "ports.tau2: missing" in done.stdout, done.stdout


def test_a_binary_for_another_platform_only_is_named(example, tmp_path):
    other = tmp_path / "other.fmu"
    with zipfile.ZipFile(example) as src, zipfile.ZipFile(other, "w") as out:
        for item in src.infolist():
            out.writestr(item.filename.replace(f"binaries/{fmpy.platform}/", "binaries/win64/"), src.read(item))
    done = _check(other, tmp_path, PORTS)
    assert done.returncode == 1, done.stdout
    assert (f"no binary for this platform: binaries/{fmpy.platform}/PdController{fmpy.sharedLibraryExtension} is "
            "missing (binaries for: win64)") in done.stdout


@pytest.mark.parametrize("ports, said", [
    ('ports = { foo = "q1" }\n', "ports.foo: not a contract name"),
    ('ports = { tau1 = 3 }\n', "ports.tau1: the FMU's variable name, a non-empty string"),
    ("tau1 = 'u1'\n", "a table ports = { contract name = \"FMU variable\", ... } and/or parameters = "),
    ('ports = { tau1 = "u1" }\nextra = 1\n', "unknown keys ['extra']"),
    ("ports = {\n", "ports.toml"),
    ('ports = { tau1 = "u1" }\nparameters = { Kp = "a" }\n', "parameters.Kp: a finite number"),
    ('ports = { tau1 = "u1" }\nparameters = { Kp = nan }\n', "parameters.Kp: a finite number"),
    ('ports = { tau1 = "u1" }\nparameters = 3\n', "parameters: a table"),
    ('ports = { tau1 = "u1" }\n[search]\nKp = { low = 1.0, high = inf }\n', "ports.toml: search.Kp.high: inf is not finite"),
    ('ports = { tau1 = "u1" }\n[search]\nKp = { choices = [1.0] }\n', "ports.toml: search.Kp.choices: [1.0]: at least 2"),
], ids=["not a contract name", "not a name", "no ports table", "an unknown key", "not TOML", "a parameter not a number", "nan",
        "parameters not a table", "a search bound not finite", "a search of one choice"])
def test_a_bad_port_map_is_one_line_and_exit_2(example, tmp_path, ports, said):
    done = _check(example, tmp_path, ports)
    assert done.returncode == 2 and done.stdout == "", done.stdout
    assert len(done.stderr.strip().splitlines()) == 1 and said in done.stderr and "Traceback" not in done.stderr


def _fmi1() -> bytes:
    """A zip whose modelDescription declares FMI 1.0 (fmpy read it with a Python error text)."""
    import io
    import zipfile

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("modelDescription.xml", '<?xml version="1.0"?>\n<fmiModelDescription fmiVersion="1.0" modelName="m" '
                   'modelIdentifier="m" guid="{0}"/>\n')
    return buf.getvalue()


@pytest.mark.parametrize("content", [None, b"not a zip", b"PK\x05\x06" + b"\0" * 18, _fmi1()],
                         ids=["missing", "text", "empty zip", "FMI 1.0"])
def test_a_file_that_is_no_fmu_is_one_line_and_exit_2(tmp_path, content):
    fmu = tmp_path / "x.fmu"
    if content is not None:
        fmu.write_bytes(content)
    done = _check(fmu, tmp_path)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1 and "x.fmu" in done.stderr, done.stderr
    assert "Traceback" not in done.stderr
    if content is not None and content.startswith(b"PK\x03"):  # the FMI 1.0 one: said as such
        assert "FMI 1.0: the contract takes FMI 2.0 or 3.0 Co-Simulation" in done.stderr, done.stderr


def test_a_file_of_parameters_alone_keeps_the_contracts_own_names(fmu_paths, tmp_path):
    """An FMU of the contract's names needs no map, only the values to set (a controller file's form is read too)."""
    done = _check(fmu_paths["CtController"], tmp_path, 'fmu = "CtController.fmu"\nparameters = { kp = 50.0 }\n')
    assert done.returncode == 0 and "tau1      -> tau1" in done.stdout and "meets the controller contract" in done.stdout
    done = _check(fmu_paths["CtController"], tmp_path, "parameters = { kp = -1.0 }\n")
    assert done.returncode == 1 and "parameters.kp = -1: outside" in done.stdout, done.stdout


@pytest.mark.slow
@pytest.mark.parametrize("fmi", [2, 3])
def test_our_own_controllers_meet_the_contract_without_a_map(request, tmp_path, fmi):
    """Every controller of ours, by the contract's names: every input it reads and both torques; in FMI 3.0,
    phi, dphi and tau are arrays of 2, whose elements stand for phi1 ... tau2 (``name[i]``, from 1)."""
    from orchestration.fmu_build.build import FMU_SOURCES

    paths = request.getfixturevalue("fmu_paths" if fmi == 2 else "fmi3_paths")
    for model in [m for m in FMU_SOURCES if m.endswith("Controller")]:
        done = _check(paths[model], tmp_path)
        assert done.returncode == 0, done.stdout
        for key in UNITS:
            own = key if fmi == 2 or key[:-1] not in ("phi", "dphi", "tau") else f"{key[:-1]}[{key[-1]}]"
            assert f"{key:9s} -> {own}" in done.stdout, done.stdout


@pytest.mark.slow
@pytest.mark.parametrize("ports, problem", [
    ({"tau1": "tau[1]", "tau2": "tau[2]", "phi1": "phi[1]"}, None),
    ({"tau1": "tau[1]", "tau2": "tau[3]"}, "ports.tau2 = 'tau[3]': the FMU has no variable 'tau[3]'"),
    ({"tau1": "tau[1]", "tau2": "tau[0]"}, "ports.tau2 = 'tau[0]': the FMU has no variable 'tau[0]'"),
    ({"tau1": "tau[1]", "tau2": "tau[2]", "phi1": "phi"}, "ports.phi1 = 'phi': an array; the contract takes one value"),
    ({"tau1": "tau[1]", "tau2": "tau[1]"}, "ports.tau2 = 'tau[1]': tau[1] is mapped to tau1 and tau2; one variable each"),
    ({"tau1": "tau[1]", "tau2": "limit_handling"}, "ports.tau2 = 'limit_handling': type Int32, the contract needs a real"),
    ("{ limit_handling = 1.5 }", "parameters.limit_handling = 1.5: limit_handling is an integer (Int32)"),
    ("{ p1 = 2000.0 }", "parameters.p1 = 2000: outside [0, 1000], the range its modelDescription declares"),
], ids=["elements", "past the end", "from 1", "a whole array", "one element twice", "an integer",
        "an integer parameter", "a parameter's range"])
def test_an_fmi3_map_names_array_elements_from_1(fmi3_paths, tmp_path, ports, problem):
    if isinstance(ports, str):  # parameters, with the torques mapped
        ports = 'ports = { tau1 = "tau[1]", tau2 = "tau[2]" }\nparameters = ' + ports + "\n"
    done = _check(fmi3_paths["CtController"], tmp_path, ports)
    assert done.returncode == (0 if problem is None else 1), done.stdout
    assert problem is None or problem in done.stdout, done.stdout


def test_an_fmi2_scalar_named_like_an_element_is_itself(example, tmp_path):
    """FMI 2.0 tools (OpenModelica, Dymola) export an array as scalars named u[1], u[2]: such a name is the variable's."""
    renamed = tmp_path / "renamed.fmu"
    with zipfile.ZipFile(example) as src, zipfile.ZipFile(renamed, "w") as out:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                data = data.replace(b'name="u1"', b'name="u[1]"').replace(b'name="u2"', b'name="u[2]"')
            out.writestr(item, data)
    done = _check(renamed, tmp_path, {**PORTS, "tau1": "u[1]", "tau2": "u[2]"})
    assert done.returncode == 0, done.stdout


def _ports_file(folder: Path, parameters: str) -> Path:
    (folder / "ports.toml").write_text(_with_parameters(parameters))
    return folder / "ports.toml"


def _main_check(fmu: Path, ports: Path, fmu_dir: Path, capsys) -> tuple[int, str]:
    from orchestration.cli import main

    code = main(["check-controller", str(fmu), "--ports", str(ports), "--fmu-dir", str(fmu_dir)])
    return code, capsys.readouterr().out


def test_the_example_passes_its_1_s_run_against_our_arm(example, tmp_path, fmu_dir, capsys):
    """Its own bound 10 N.m over the paper's 4: the actuator cuts some samples, and the run says how many."""
    code, out = _main_check(example, _ports_file(tmp_path, "{ Kp = 10.0, Kd = 3.0, umax = 10.0 }"), fmu_dir, capsys)
    assert code == 0, out
    lines = out.splitlines()
    assert "  1 s run against our arm (scenario paper, rho = 4 N.m): finished, 101 samples" in lines, out
    assert "    every torque it wrote (u1, u2) is finite" in lines and lines[-1] == "  passes the 1 s run", out
    assert "    max ||tau|| it wrote: 10 N.m; samples the actuator cut: " in out, out
    cuts = int(out.split("samples the actuator cut: ")[1].split(" of ")[0])
    assert 0 < cuts < 101 and "    tracking error at t = 1 s: e1 = " in out, out


def test_a_run_the_fmu_fails_is_exit_1_with_its_reason(example, tmp_path, fmu_dir, capsys):
    """umax = -1: its modelDescription declares no range, so the contract lets it through; the FMU refuses it."""
    code, out = _main_check(example, _ports_file(tmp_path, "{ umax = -1.0 }"), fmu_dir, capsys)
    assert code == 1 and "meets the controller contract" in out, out
    [failed] = [line for line in out.splitlines() if "FAILED" in line]
    assert failed.startswith("  1 s run against our arm") and "umax = -1 refused: must be finite and > 0" in failed
    assert out.splitlines()[-1] == "  fails the 1 s run"


def test_an_fmu_that_breaks_the_contract_does_not_run(example, tmp_path, capsys):
    """A problem in the interface: exit 1 before anything is built or loaded (the FMU folder is not made)."""
    ports = tmp_path / "ports.toml"
    ports.write_text('ports = { tau1 = "u1", tau2 = "Kp" }\n')
    code, out = _main_check(example, ports, tmp_path / "fmus", capsys)
    assert code == 1 and "run against our arm" not in out and not (tmp_path / "fmus").exists(), out


def test_a_pythonfmu_controller_written_as_a_user_would_meets_the_contract_and_runs(fmu_paths, tmp_path):
    """pythonfmu alone, none of our FMU framework (``tests/support/user_pythonfmu/user_pd.py``): checked, then run
    in place of our controller in a child process (``orchestration.run.isolated``)."""
    from support import hostile, user_pythonfmu

    from orchestration.run import isolated

    fmu = user_pythonfmu.build(tmp_path)
    done = _check(fmu, tmp_path)
    assert done.returncode == 0 and "meets the controller contract" in done.stdout, done.stdout
    result = isolated.run(hostile.controlled_by("UserPd"), {**fmu_paths, "UserPd": fmu})
    assert not result.failed and result.samples == 201, result.error
    torques = result.outputs["controller"]
    assert torques["tau1"][0] == 0.0 and all(abs(torques[t][1:]).min() > 0 for t in ("tau1", "tau2"))


def test_a_hostile_controller_meets_the_contract_until_it_runs(tmp_path, monkeypatch):
    """The check reads the interface: a controller that crashes in its doStep passes it; its run fails alone
    (``tests/faults/test_isolated_runs.py``)."""
    from support import hostile

    done = _check(hostile.build("segv", tmp_path, monkeypatch), tmp_path)
    assert done.returncode == 0 and "meets the controller contract" in done.stdout, done.stdout


def test_a_plain_c_fmi3_controller_meets_the_contract_and_runs_as_its_fmi2_twin(fmu_paths, tmp_path, monkeypatch):
    """The example's PD controller as FMI 3.0 in plain C (``tests/support/fmi3_pd``): checked, then run in a child
    process; its torques are those of the same C code as FMI 2.0 (a hostile twin, until its fault at t = 1 s)."""
    import numpy as np
    from support import fmi3_pd, hostile

    from orchestration.run import isolated, master

    fmu = fmi3_pd.build(tmp_path)
    done = _check(fmu, tmp_path)
    assert done.returncode == 0 and "meets the controller contract" in done.stdout, done.stdout
    result = isolated.run(hostile.controlled_by(fmi3_pd.IDENTIFIER), {**fmu_paths, fmi3_pd.IDENTIFIER: fmu})
    assert not result.failed and result.samples == 201, result.error
    twin_fmu = hostile.build("error", tmp_path, monkeypatch)
    twin = master.run(hostile.scenario("error"), {**fmu_paths, "HostileError": twin_fmu})
    n = twin.samples
    assert n == hostile.FAULT_SAMPLE + 1
    for torque in ("tau1", "tau2"):
        assert np.array_equal(result.outputs["controller"][torque][:n], twin.outputs["controller"][torque])


def test_a_model_description_is_read_once_per_file_as_it_is(example, tmp_path):
    """A sweep checks each of its points against the contract: one file is parsed once, again once it changed."""
    from orchestration.compliance.contract import model_description

    fmu = tmp_path / "c.fmu"
    fmu.write_bytes(example.read_bytes())
    first = model_description(fmu)
    assert model_description(fmu) is first
    with zipfile.ZipFile(fmu, "a") as z:
        z.writestr("documentation/note.txt", "changed")
    assert model_description(fmu) is not first and model_description(fmu).guid == first.guid
