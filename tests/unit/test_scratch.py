"""Folders named after their owner process (``orchestration.scratch``): only this host's folders whose
process is gone are removed; a live owner's, another host's and foreign names are kept."""
from __future__ import annotations

import os
import subprocess

from orchestration.scratch import owner_gone, owner_prefix, remove_stale, scratch_name


def _dead_pid() -> int:
    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


def test_only_folders_of_gone_owners_on_this_host_are_removed(tmp_path):
    host = scratch_name().split("-")[0]
    dead = _dead_pid()
    names = {
        "dead": f"{host}-{dead}-1",
        "mine": scratch_name(),
        "parent": f"{host}-{os.getppid()}-2",
        "other host": f"elsewhere-{dead}-3",
        "foreign": "not-a-scratch",
    }
    for name in names.values():
        (tmp_path / name / "dask").mkdir(parents=True)
    removed = remove_stale(tmp_path)
    assert removed == [tmp_path / names["dead"]]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(v for k, v in names.items() if k != "dead")


def test_a_prefix_is_part_of_the_name():
    name = owner_prefix("sotc_stage_") + "abc"
    assert name.startswith("sotc_stage_") and not owner_gone(name, "sotc_stage_")  # this process: alive
    assert not owner_gone(name, "sotc_cython_")
