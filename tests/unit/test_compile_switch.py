"""The compile switch: compiled cores are the default wherever they can be built; ``SOTC_COSIM_COMPILE=0``
keeps the cores Python; ``=1`` insists (the build then says why it cannot). Every hot module has its
declarations beside it, and they name only functions the module defines."""
from __future__ import annotations

import ast
import os
import re
from pathlib import Path

import pytest

from orchestration.fmu_build import compiled

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("value, requested, insisted", [(None, True, False), ("1", True, True), ("0", False, False)])
def test_the_switch(monkeypatch, value, requested, insisted):
    if value is None:
        monkeypatch.delenv(compiled.SWITCH, raising=False)
    else:
        monkeypatch.setenv(compiled.SWITCH, value)
    assert compiled.requested() is requested and compiled.insisted() is insisted


def test_switched_restores_the_environment(monkeypatch):
    monkeypatch.setenv(compiled.SWITCH, "1")
    with compiled.switched(False):
        assert not compiled.requested()
    assert compiled.insisted()
    monkeypatch.delenv(compiled.SWITCH)
    with compiled.switched(True):
        assert compiled.insisted()
    assert compiled.SWITCH not in os.environ


def test_each_declaration_file_types_functions_its_module_defines():
    typed = 0
    for rel in compiled.HOT:
        pxd = ROOT / compiled.declarations(rel)
        if not pxd.is_file():
            continue
        defined = {n.name for n in ast.walk(ast.parse((ROOT / rel).read_text())) if isinstance(n, ast.FunctionDef)}
        declared = re.findall(r"^cp?def\s+(?:\([^)]*\)|\w+)\s+(\w+)\(", pxd.read_text(), re.M)
        assert set(declared) <= defined, (rel, set(declared) - defined)
        typed += len(declared)
    assert typed >= 30
