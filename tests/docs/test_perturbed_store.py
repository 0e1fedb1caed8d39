"""The stored perturbed runs of the generated tables (docs/perturbed.json, orchestration.reports.perturbed):
what docgen write stores is what the code computes, in a deterministic form, and rendering refuses a store
whose nominal runs are not the code's to the bit."""
import json
from pathlib import Path

import pytest

from orchestration.reports import docgen, perturbed
from orchestration.study.comparison import PERTURBATIONS, controller_of, tuned_run

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def tiny(tmp_path, monkeypatch):
    """A checkout in tmp_path with one block printing one stood-in figure of `paper` (the figure's value
    is ``figure[0]`` for the nominal run and each perturbation's first entry plus one for the others)."""
    figure = [0.25]

    def loop(fmu, params, stop_time, perturbation=(0.0, 0.0, 0.0, 0.0)):
        return {"x": figure[0] + perturbation[0] * 1e11}

    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "tiny.md").write_text("<!-- BEGIN generated:tiny -->\n<!-- END generated:tiny -->\n")
    monkeypatch.setattr(docgen, "ROOT", tmp_path)
    monkeypatch.setitem(perturbed.FIGURES, "loop", loop)
    monkeypatch.setattr(docgen, "BLOCKS", {"tiny": docgen.Block(
        "docs/tiny.md", lambda: docgen.stable(*(lambda m, ns: (m["x"], [n["x"] for n in ns]))(*perturbed.metrics("paper"))),
        True)})
    return tmp_path, figure


def test_write_stores_the_perturbed_runs_and_check_reads_them(tiny, capsys):
    root, _ = tiny
    assert docgen.main(["write", "--workers", "1"]) == 0
    data = json.loads((root / perturbed.STORE).read_text())
    (entry,) = data["runs"].values()
    assert entry["nominal"] == {"x": 0.25} and len(entry["perturbed"]) == len(PERTURBATIONS)
    assert entry["perturbed"][0] == {"x": 0.25 + PERTURBATIONS[0][0] * 1e11}
    assert docgen.committed("tiny") == docgen.render("tiny") and docgen.main(["check"]) == 0
    assert "chaotic" in docgen.committed("tiny")  # 0.25 +- 10 (from the perturbations 1e-10): the range


def test_a_nominal_run_one_bit_off_the_store_is_stale(tiny, capsys):
    root, figure = tiny
    assert docgen.main(["write", "--workers", "1"]) == 0
    figure[0] = 0.25 + 2 ** -54  # the next double above 0.25
    with pytest.raises(perturbed.Stale, match="^stale: run python -m orchestration.reports.docgen write tiny "):
        docgen.render("tiny")
    assert docgen.main(["check", "tiny"]) == 1
    assert "stale: run python -m orchestration.reports.docgen write tiny" in capsys.readouterr().out
    assert docgen.main(["write", "tiny", "--workers", "1"]) == 0 and docgen.main(["check"]) == 0


def test_a_bad_worker_count_is_one_line_and_exit_2(capsys):
    assert docgen.main(["write", "--workers", "0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--workers must be at least 1" in err


def test_the_store_is_written_deterministically():
    """Sorted keys, floats as their repr (json's), one form for one content: a rewrite changes no byte."""
    text = (REPO / perturbed.STORE).read_text()
    assert json.dumps(json.loads(text), indent=1, sort_keys=True) + "\n" == text


def _loop_key(scenario, **overrides):
    fmu, params = controller_of(scenario, **overrides)
    return perturbed.key("loop", [fmu, sorted([k, v] for k, v in params.items()), 100.0])


@pytest.mark.slow
@pytest.mark.parametrize("what, index", [("tuned SOTC", 0), ("CT", 5), ("SOTC state", 7), ("ladder", 47)])
def test_a_sample_of_the_stored_perturbed_runs_is_what_the_code_computes(what, index):
    """One perturbation each of four stored configurations (the tuned SOTC under accel, CT at its scenario's
    defaults, the SOTC's own state in `paper`, the tuned SOTC of seed 4 under accel in the ladder table, which
    reads its nominal runs from the store too), recomputed now: the same bits."""
    if what == "ladder":
        from fmu_controller.saturation import ACCEL
        from orchestration.study import fair

        fmu, params = fair.configurations(ACCEL)[fair.tuned_label("SotcController", 4)]
        at = perturbed.key("loop", [fmu, sorted([k, v] for k, v in params.items()), 100.0])
        assert json.dumps(perturbed.FIGURES["loop"](*json.loads(at)[1:]), sort_keys=True) == json.dumps(
            perturbed.stored(REPO)[at]["nominal"], sort_keys=True)
    elif what == "tuned SOTC":
        scenario, overrides = tuned_run("SotcController", 2)
        at = _loop_key(scenario, **overrides)
    elif what == "CT":
        at = _loop_key("paper-ct", limit_handling=0)
    else:
        _, params = controller_of("paper")
        at = perturbed.key("sotc", [sorted([k, v] for k, v in params.items()), 100.0])
    runs = perturbed.stored(REPO)
    assert at in runs, f"{perturbed.STORE} has no {what}: run python -m orchestration.reports.docgen write"
    assert json.dumps(perturbed.recompute(at, index), sort_keys=True) == json.dumps(runs[at]["perturbed"][index],
                                                                                   sort_keys=True)
