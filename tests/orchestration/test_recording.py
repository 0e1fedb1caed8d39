"""Rerun recordings: read the .rrd files back and compare them with the master's arrays."""
from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from rerun.chunk import RrdReader

from orchestration.cli import main
from orchestration.recording.blueprint import TABS, VIEW_DESCRIPTIONS
from orchestration.recording.overlays import record_comparison
from orchestration.recording.rrd_file import APPLICATION_ID
from orchestration.recording.writer import BLOCK_SIZE, RunRecorder
from orchestration.run.master import run
from orchestration.run.scenario import load_scenario
from support.rrd_contents import read_entities, statics

STEP_NS = 10_000_000  # T = 0.01 s


def scalars(entity: dict) -> np.ndarray:
    return np.array(entity["Scalars:scalars"], dtype=float)


def stack(result, instance: str) -> np.ndarray:
    return np.column_stack(list(result.outputs[instance].values()))


RERUN = str(Path(sys.executable).with_name("rerun"))  # the CLI that ships with rerun-sdk


def _verify(*paths: Path) -> None:
    proc = subprocess.run([RERUN, "rrd", "verify", *map(str, paths)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


@pytest.fixture(scope="module")
def ct_run(fmu_paths, tmp_path_factory):
    """The full 100 s paper-ct run, recorded."""
    path = tmp_path_factory.mktemp("rec") / "paper-ct.rrd"
    with RunRecorder(path) as rec:
        result = run(load_scenario("paper-ct"), fmu_paths, observer=rec, block_size=BLOCK_SIZE)
    assert not result.failed
    return result, path, read_entities(path)


@pytest.fixture(scope="module")
def sotc_run(fmu_paths, tmp_path_factory):
    """5 s of the SOTC paper scenario (weights, tau*, tau^a, PE/CL events), small blocks."""
    path = tmp_path_factory.mktemp("rec") / "paper.rrd"
    with RunRecorder(path) as rec:
        result = run(load_scenario("paper").with_stop_time(5.0), fmu_paths, observer=rec, block_size=128)
    assert not result.failed
    return result, path, read_entities(path)


def test_every_output_of_every_fmu_has_one_row_per_step_with_the_exact_values(ct_run):
    result, path, ents = ct_run
    assert result.samples == 10_001
    steps = np.arange(10_001)
    for inst, outputs in result.outputs.items():
        e = ents[f"/fmu/{inst}"]
        assert np.array_equal(e["step"], steps)
        assert np.array_equal(e["sim_time"], steps * STEP_NS)  # integer ns, never float seconds
        assert np.array_equal(scalars(e), stack(result, inst))
        assert statics(path)[f"/fmu/{inst}"]["SeriesLines:names"] == [list(outputs)]
    for entity, e in ents.items():
        if not entity.startswith("/events"):
            assert np.array_equal(e["step"], steps), entity


def test_grouped_entities_hold_the_paper_figures_series(ct_run):
    result, _, ents = ct_run
    p, r, c = result.outputs["plant"], result.outputs["reference"], result.outputs["controller"]
    for i in (1, 2):
        assert np.array_equal(scalars(ents[f"/joints/phi{i}"]), np.column_stack([p[f"phi{i}"], r[f"phi{i}_d"]]))
    assert np.array_equal(scalars(ents["/tracking/error"]),
                          np.column_stack([p["phi1"] - r["phi1_d"], p["phi2"] - r["phi2_d"]]))
    assert np.array_equal(scalars(ents["/torques/tau"]),
                          np.column_stack([c["tau1"], c["tau2"], np.hypot(c["tau1"], c["tau2"])]))
    assert np.array_equal(scalars(ents["/torques/limit"]), np.tile([4.0, -4.0], (result.samples, 1)))
    ee = np.column_stack([p["ee_x"], p["ee_y"]]).astype(np.float32)
    elbow = np.column_stack([p["elbow_x"], p["elbow_y"]]).astype(np.float32)
    arm = np.array(ents["/workspace/arm"]["LineStrips2D:strips"], dtype=np.float32)  # (n, 1 strip, 3 points, 2)
    assert np.array_equal(arm[:, 0], np.stack([np.zeros_like(ee), elbow, ee], axis=1))
    path = np.array(ents["/workspace/path/actual"]["LineStrips2D:strips"], dtype=np.float32)[:, 0]
    assert np.array_equal(path[1:, 0], ee[:-1]) and np.array_equal(path[:, 1], ee)
    target = np.array(ents["/workspace/target"]["Points2D:positions"], dtype=np.float32)[:, 0]
    assert np.array_equal(target, np.column_stack([r["x_d"], r["y_d"]]).astype(np.float32))
    assert "/controller/weights" not in ents  # the CT controller has no critic


def test_sotc_series_and_events_come_from_the_diagnostics(sotc_run):
    result, path, ents = sotc_run
    c = result.outputs["controller"]
    assert np.array_equal(scalars(ents["/controller/weights"]), np.column_stack([c[f"W{k}"] for k in range(1, 11)]))
    assert np.array_equal(scalars(ents["/torques/tau_star"]), np.column_stack([c["tau_star1"], c["tau_star2"]]))
    assert np.array_equal(scalars(ents["/torques/tau_a"]), np.column_stack([c["tau_a1"], c["tau_a2"]]))
    assert len(ents["/fmu/controller"]["step"]) == result.samples == 501

    pe_off = int(np.flatnonzero(c["pe_active"] == 0)[0])
    pe = ents["/events/pe"]
    assert list(pe["step"]) == [0, pe_off] and "switched off" in pe["TextLog:text"][1][0]
    cl = ents["/events/cl"]
    first = int(np.flatnonzero(c["cl_stack_size"] > 0)[0])
    assert cl["step"][0] == first and cl["TextLog:text"][0][0].startswith("CL switched on")
    assert list(cl["step"]) == list(np.flatnonzero(np.diff(c["cl_stack_size"], prepend=0.0)))
    law = ents["/events/tuning_law"]
    assert list(law["step"]) == [0, *(np.flatnonzero(np.diff(c["tuning_law"])) + 1)]
    clip = ents["/events/clipping"]
    bounded = np.concatenate(([0.0], c["tau_a_bounded"]))
    edges = set(np.flatnonzero(np.diff(bounded)))
    assert edges <= set(clip["step"])
    assert ents["/events/run"]["TextLog:level"][-1] == ["INFO"]


def test_blueprint_properties_and_identity_are_stored(ct_run, sotc_run, fmu_paths):
    (_, ct_path, _), (_, sotc_path, _) = ct_run, sotc_run
    readers = [RrdReader(ct_path), RrdReader(sotc_path)]
    ids = set()
    for reader in readers:
        (rec,), (bp,) = reader.recordings(), reader.blueprints()
        assert rec.application_id == bp.application_id == APPLICATION_ID
        ids.add(rec.recording_id)
        reader.store()  # the footer (manifest) was written: the file was finalised
    assert len(ids) == 2
    names = []
    for chunk in readers[1].stream(store=readers[1].blueprints()[0]).to_chunks():
        rb = chunk.to_record_batch()
        names += [v[0] for n in rb.schema.names if n.endswith("display_name") for v in rb.column(n).to_pylist()]
    for fig in ("Fig. 1-2", "Fig. 3", "Fig. 4", "Fig. 5", "Fig. 6", "Fig. 7", "Fig. 8", "Fig. 9"):
        assert any(n.startswith(fig) for n in names), fig
    assert max(len(n) for n in names) <= 16, names  # titles readable at 1600 x 1000; details in "views"
    assert set(names) <= set(VIEW_DESCRIPTIONS) | set(TABS) | {"plant", "reference", "controller"}
    props = statics(sotc_path)
    assert props["/__properties/scenario"]["name"] == [["paper"]]
    assert props["/__properties/scenario"]["stop_time"] == [[5.0]]
    assert props["/__properties/scenario"]["step_size"] == [[0.01]]
    assert props["/__properties/plant"]["phi1_0"] == [[0.5]]
    assert props["/__properties/controller"]["fmu"][-1] == ["SotcController"]
    md = read_model_description(str(fmu_paths["SotcController"]))
    assert props["/__properties/controller"]["fmu_guid"][-1] == [md.guid]
    assert props["/__properties/controller"]["fmu_version"][-1] == [md.version] and md.version
    assert "Fig. 9: path" in props["/__properties/views"]
    assert props["/__properties/result"]["status"] == [["ok"]]
    assert props["/__properties"]["RecordingInfo:name"] == [["paper"]]
    _verify(ct_path, sotc_path)


def test_a_failed_run_is_recorded_with_its_reason(fmu_paths, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('extends = "paper-ct"\nname = "bad"\nstop_time = 1.0\n[instances.controller]\nparameters = { kp = -5.0 }\n')
    path = tmp_path / "bad.rrd"
    with RunRecorder(path) as rec:
        result = run(load_scenario(str(bad)), fmu_paths, observer=rec)
    assert result.failed
    ents = read_entities(path)
    assert ents["/events/run"]["TextLog:level"] == [["ERROR"]] and "'kp'" in ents["/events/run"]["TextLog:text"][0][0]
    assert statics(path)["/__properties/result"]["status"] == [["failed"]]
    _verify(path)


def test_an_exception_during_the_run_still_finalises_the_file(fmu_paths, tmp_path):
    path = tmp_path / "boom.rrd"

    class Exploding(RunRecorder):
        def block(self, time, rows):
            super().block(time, rows)
            if self.writer.next_step >= 200:
                raise RuntimeError("observer bug")

    with Exploding(path) as rec:
        result = run(load_scenario("paper-ct"), fmu_paths, observer=rec, block_size=100)
    assert result.failed and "observer bug" in result.error  # the run stops and says why
    RrdReader(path).store()  # footer present
    ents = read_entities(path)
    assert len(ents["/fmu/plant"]["step"]) == 200
    assert "observer bug" in ents["/events/run"]["TextLog:text"][-1][0]


KILLED_SCRIPT = textwrap.dedent('''
    import sys, time
    from pathlib import Path
    from orchestration.run.master import run
    from orchestration.recording.writer import RunRecorder
    from orchestration.run.scenario import load_scenario

    class StopsAfterThreeBlocks:
        def __init__(self, recorder):
            self.recorder, self.blocks = recorder, 0
        def start(self, scenario, columns, parameters):
            self.recorder.start(scenario, columns, parameters)
        def block(self, time_, rows):
            self.recorder.block(time_, rows)
            self.blocks += 1
            if self.blocks == 3:
                print("3 blocks written", flush=True)
                while True:  # wait here to be killed
                    time.sleep(60)
        def finish(self, result):
            self.recorder.finish(result)

    fmus = {p.stem: p for p in Path(sys.argv[2]).glob("*.fmu")}
    run(load_scenario("paper-ct"), fmus, observer=StopsAfterThreeBlocks(RunRecorder(sys.argv[1])), block_size=500)
''')


@pytest.mark.filterwarnings("ignore:RRD file has no footer")
def test_a_killed_run_leaves_a_readable_prefix(fmu_dir, fmu_paths, tmp_path):
    script, path = tmp_path / "killed.py", tmp_path / "killed.rrd"
    script.write_text(KILLED_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(script), str(path), str(fmu_dir)], stdout=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()  # the third block is in the file once this line arrives
        assert line.strip() == "3 blocks written", line
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert not path.exists()  # only a finished recording is renamed into place
    path, = tmp_path.glob(".killed.rrd.*.part")
    ents = read_entities(path)  # no footer, no finish: the temporary file is still readable
    reference = run(load_scenario("paper-ct").with_stop_time(15.0), fmu_paths)
    for inst in reference.outputs:
        e = ents[f"/fmu/{inst}"]
        assert np.array_equal(e["step"], np.arange(1500))
        assert np.array_equal(scalars(e), stack(reference, inst)[:1500])
    # rerun's own tools read it too: optimize adds the footer the killed run could not write
    fixed = tmp_path / "fixed.rrd"
    subprocess.run([RERUN, "rrd", "optimize", str(path), "-o", str(fixed)], check=True, capture_output=True)
    _verify(fixed)
    assert len(read_entities(fixed)["/fmu/plant"]["step"]) == 1500


def test_cli_writes_a_recording_per_run_unless_told_otherwise(fmu_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    common = ["--stop-time", "0.5", "--fmu-dir", str(fmu_dir)]
    assert main(["run", "paper-ct", *common]) == 0
    assert len(read_entities(tmp_path / "recordings" / "paper-ct.rrd")["/fmu/plant"]["step"]) == 51
    (tmp_path / "here").mkdir()  # a folder outside recordings/ is not made for a file (test_cli_refusals.py)
    assert main(["run", "paper-ct", "--recording", "here/x.rrd", *common]) == 0
    assert (tmp_path / "here" / "x.rrd").is_file()
    (tmp_path / "recordings" / "paper-ct.rrd").unlink()
    assert main(["run", "paper-ct", "--no-recording", *common]) == 0
    assert not (tmp_path / "recordings" / "paper-ct.rrd").exists()
    assert main(["run", "paper-ct", "paper", "--recording", "y.rrd", *common]) == 2
    assert "recording: recordings/paper-ct.rrd" in capsys.readouterr().out


def test_compare_overlays_the_runs_in_one_recording(fmu_dir, fmu_paths, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["compare", "paper", "paper-ct", "--stop-time", "2", "--fmu-dir", str(fmu_dir)]) == 0
    out = capsys.readouterr().out.splitlines()
    first = next(i for i, line in enumerate(out) if line.startswith("scenario"))  # the table
    assert [line.split(",")[0] for line in out[:first]] == ["compare: 1/2 done", "compare: 2/2 done"]  # progress
    path = tmp_path / "recordings" / "compare.rrd"
    ents = read_entities(path)
    for name in ("paper", "paper-ct"):
        result = run(load_scenario(name).with_stop_time(2.0), fmu_paths)
        p, r, c = result.outputs["plant"], result.outputs["reference"], result.outputs["controller"]
        for i in (1, 2):
            assert np.array_equal(scalars(ents[f"/{name}/tracking/e{i}"])[:, 0], p[f"phi{i}"] - r[f"phi{i}_d"])
            assert np.array_equal(scalars(ents[f"/{name}/torques/tau{i}"])[:, 0], c[f"tau{i}"])
        assert np.array_equal(scalars(ents[f"/{name}/fmu/controller"]), stack(result, "controller"))
        assert len(ents[f"/{name}/workspace/path/actual"]["step"]) == 201
    assert np.array_equal(scalars(ents["/limit"]), np.tile([4.0, -4.0], (201, 1)))
    assert RrdReader(path).blueprints()
    _verify(path)


def test_compare_keeps_runs_of_the_same_scenario_apart(fmu_paths, tmp_path):
    a = run(load_scenario("paper-ct").with_stop_time(0.2), fmu_paths)
    ents = read_entities(record_comparison([a, a], tmp_path / "same.rrd"))
    assert {"/paper-ct/tracking/e1", "/paper-ct-2/tracking/e1"} <= set(ents)


def test_record_every_keeps_every_nth_step_and_every_event(fmu_paths, tmp_path):
    """`--record-every N` for long runs: signals at k % N == 0 with their exact values and times,
    events (here PE off at 0.4 s, CL on) still at the step where they happen."""
    full, thin = tmp_path / "full.rrd", tmp_path / "thin.rrd"
    scenario = load_scenario("paper").with_stop_time(3.0)
    with RunRecorder(full) as rec:
        result = run(scenario, fmu_paths, observer=rec, block_size=128)
    with RunRecorder(thin, every=7) as rec:
        run(scenario, fmu_paths, observer=rec, block_size=128, keep_samples=False)
    _verify(thin)
    a, b = read_entities(full), read_entities(thin)
    kept = np.arange(0, 301, 7)
    for inst in result.outputs:
        e = b[f"/fmu/{inst}"]
        assert np.array_equal(e["step"], kept) and np.array_equal(e["sim_time"], kept * STEP_NS)
        assert np.array_equal(scalars(e), stack(result, inst)[kept])
    events = [k for k in a if k.startswith("/events")]
    assert events and all(np.array_equal(a[k]["step"], b[k]["step"]) and a[k]["TextLog:text"] == b[k]["TextLog:text"]
                          for k in events if k != "/events/run")
    assert thin.stat().st_size < full.stat().st_size


def test_cli_record_every_is_checked(fmu_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(["run", "paper-ct", "--record-every", "0", "--fmu-dir", str(fmu_dir)])
    assert exc.value.code == 2 and "--record-every" in capsys.readouterr().err
    assert main(["run", "paper-ct", "--stop-time", "1", "--record-every", "10", "--fmu-dir", str(fmu_dir)]) == 0
    assert list(read_entities(tmp_path / "recordings" / "paper-ct.rrd")["/fmu/plant"]["step"]) == list(range(0, 101, 10))


def test_fig9_bounds_hold_the_arm_base_and_the_whole_circle_with_a_margin():
    from orchestration.recording.blueprint import WORKSPACE_X, WORKSPACE_Y

    theta = np.linspace(0.0, 2.0 * np.pi, 361)
    xs = np.concatenate(([0.0, 1.88], 1.0 + 0.5 * np.sin(0.5 * theta + np.pi / 2)))  # base, E(0), circle (47)
    ys = -np.concatenate(([0.0, 0.48], 1.0 + 0.5 * np.cos(0.5 * theta + np.pi / 2)))  # the view mirrors y
    margin = 0.1
    assert WORKSPACE_X[0] + margin <= xs.min() and xs.max() <= WORKSPACE_X[1] - margin
    assert WORKSPACE_Y[0] + margin <= ys.min() and ys.max() <= WORKSPACE_Y[1] - margin


# ``sotc-cosim run`` in a fresh interpreter whose shared halves hold no block: every block is pickled
PICKLED_BLOCKS = ("import sys\nfrom orchestration.recording.writer_process import SharedBlocks\n"
                  "SharedBlocks.HALF = 4096\nfrom orchestration.cli import main\nsys.exit(main(sys.argv[1:]))")


@pytest.mark.parametrize("blocks", ["shared", "pickled"])
def test_the_commands_writer_process_records_what_a_run_recorder_records(fmu_dir, ct_run, tmp_path, blocks):
    """``sotc-cosim run`` writes through its child process: the same entities, steps and values as
    the in-process ``RunRecorder`` of the same run (``ct_run``), whether its blocks go through the
    shared memory or (larger than it) through the pipe."""
    import subprocess
    import sys

    from support.cli import SCRIPT, TIME_LIMIT, env_for

    argv = ["run", "paper-ct", "--recording", "child.rrd", "--fmu-dir", str(fmu_dir)]
    command = [SCRIPT, *argv] if blocks == "shared" else [sys.executable, "-c", PICKLED_BLOCKS, *argv]
    proc = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, env=env_for(tmp_path),
                          timeout=TIME_LIMIT)
    assert proc.returncode == 0, proc.stderr
    mine, reference = read_entities(tmp_path / "child.rrd"), ct_run[2]
    assert sorted(mine) == sorted(reference)
    for entity in reference:
        assert sorted(mine[entity]) == sorted(reference[entity]), entity
        for column, values in reference[entity].items():
            if entity != "/events/run":  # its text says the run's wall time
                assert np.array_equal(mine[entity][column], values), (entity, column)


def test_shared_blocks_alternate_halves_and_refuse_a_block_larger_than_one():
    from orchestration.recording.writer_process import SharedBlocks

    shared = SharedBlocks()
    first = {"a": np.arange(6.0).reshape(3, 2), "b": np.full((3, 1), -0.0)}
    second = {"a": np.arange(6.0).reshape(3, 2) + 10.0, "b": np.full((3, 1), np.nan)}
    one, two = shared.put(first), shared.put(second)
    assert one[0][1] == 0 and two[0][1] == SharedBlocks.HALF  # the second block does not overwrite the first
    for layout, rows in ((one, first), (two, second)):
        got = shared.rows(layout)
        for name, values in rows.items():
            assert got[name].tobytes() == values.tobytes(), name  # bit for bit, signed zeros and NaN included
    assert shared.put({"a": np.zeros(SharedBlocks.HALF // 8 + 1)}) is None
