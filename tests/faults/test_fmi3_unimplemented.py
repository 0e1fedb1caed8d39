"""FMI 3 calls that pythonfmu3 0.3.4's binary does not implement ended the host: it throws
``std::logic_error`` ("function fmi3GetFloat32 not implemented") out of a C function, and the process
aborts (SIGABRT, exit 134). The FMU's binary (the shim, ``orchestration/fmu_build/fmi3_shim.c``) answers
each with fmi3Error and a logged message, and the instance goes on: a get or set of a type the variable
does not have (Float32, the 8- and 16-bit integers, UInt32 and Binary with the right nValues, a clock)
and the functions the FMU declares nothing for (per-element dependencies, adjoint derivatives, discrete
states, model partitions, the intervals and shifts of clocks). Every call runs in one child process, in
order (``support.fmi_child``): a call that aborts it leaves its own line and every later one missing."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from support import child_env
from support.fmi_child import ARRAY, CALLS, UNIMPLEMENTED_TYPES

ERROR = 3  # fmi3Error
TYPED = [c for c in CALLS if c[:3] in ("get", "set")]  # 14 of the types above, and the clock's get and set
FUNCTIONS = [c for c in CALLS if c not in TYPED]


@pytest.fixture(scope="module")
def answers(shimmed_arm3, tmp_path_factory) -> dict:
    tmp = tmp_path_factory.mktemp("calls")
    proc = subprocess.run([sys.executable, "-m", "support.fmi_child", str(shimmed_arm3), *CALLS], cwd=tmp,
                          capture_output=True, text=True, timeout=300, env={**child_env(), "TMPDIR": str(tmp)})
    steps = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    return {s["step"]: s for s in steps} | {"exit": proc.returncode, "stderr": proc.stderr[-1500:]}


def _answer(answers: dict, call: str) -> dict:
    assert call in answers, f"the host ended before {call} returned: exit {answers['exit']}\n{answers['stderr']}"
    assert answers[call]["status"] == ERROR, answers[call]
    return answers[call]


def test_the_fourteen_unimplemented_gets_and_sets_are_all_covered():
    pairs = {f"{verb}{kind}" for kind in UNIMPLEMENTED_TYPES for verb in ("get", "set")}
    assert len(pairs) == 14 and pairs <= set(TYPED)


@pytest.mark.parametrize("call", TYPED)
def test_a_get_or_set_of_a_type_the_variable_does_not_have_is_an_error_naming_it(answers, call):
    verb, kind = ("read", call[3:]) if call.startswith("get") else ("set", call[3:])
    messages = [text for status, text in _answer(answers, call)["messages"] if status == ERROR]
    assert [t for t in messages if f"'{ARRAY}' is a Float64 variable, not {kind}; nothing was {verb}" in t], messages


@pytest.mark.parametrize("call", FUNCTIONS)
def test_a_function_the_fmu_declares_nothing_for_is_an_error_naming_it(answers, call):
    messages = [text for status, text in _answer(answers, call)["messages"] if status == ERROR]
    assert [t for t in messages if t.startswith(f"fmi3{call}: the FMU ")], messages


def test_after_every_refused_call_the_instance_holds_its_values_and_steps(answers):
    assert answers["exit"] == 0, answers["stderr"]
    assert answers["goes on"]["held"] == [0.5, -0.25]
