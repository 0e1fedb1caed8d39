"""The perturbed runs of the generated tables, paid once.

Every printed figure is judged over its run under each of ``comparison.PERTURBATIONS``
(``orchestration.markdown.stable``): 49 100 s runs a figure. ``docgen write`` computes the perturbed
runs of the blocks it writes (on a process pool) and stores, per configuration, the figures the tables
print of its nominal run and of each perturbed one in ``STORE`` (JSON, floats as their repr, sorted
keys). Rendering a block (``docgen check``, tests/docs/test_docgen.py) recomputes only the nominal runs
and reads the perturbed figures from the store; it refuses (``Stale``) when a recomputed nominal figure
differs from the stored one by one bit, so that a change of the code cannot leave stale perturbed figures.
"""
from __future__ import annotations

import contextlib
import functools
import json
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

from fmu_plant.paper_setting import SUBSTEPS
from orchestration.outputs import atomic_write
from orchestration.progress import Progress
from orchestration.study.comparison import NOMINAL, PERTURBATIONS, controller_of, loop_result, loop_run, tuned_run

STORE = "docs/perturbed.json"
SOTC = "SotcController"  # the core the "sotc" and "value" figures read
# the metrics (orchestration.run.metrics.tracking_metrics) the tables print
PRINTED = ("last_limit_time", "max_tau_norm", "mse", "mse_after_5s", "mse_after_limit", "samples_over_limit",
           "tracking_cost")
Figures = dict[str, Any]


class Stale(Exception):
    """The store does not hold what the code computes now."""


def _plain(value: Any) -> Any:
    """``value`` with numpy scalars and arrays, and tuples, as plain JSON values."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)) or hasattr(value, "tolist") and getattr(value, "ndim", 0):
        return [_plain(v) for v in list(value)]
    if hasattr(value, "item"):
        return value.item()
    return value


def _text(value: Any) -> str:
    """The stored form: equal texts are equal bits (repr of every float)."""
    return json.dumps(value, sort_keys=True)


def loop_figures(fmu: str, params: list[list[Any]], stop_time: float,
                 perturbation: tuple[float, ...] = NOMINAL) -> Figures:
    """The printed metrics of a controller core in the pure loop (``comparison.loop_run``)."""
    m = loop_run(fmu, tuple((k, v) for k, v in params), stop_time, SUBSTEPS, tuple(perturbation))
    return _plain({k: m[k] for k in PRINTED})


def _sotc_run(params: str, stop_time: float, perturbation: tuple[float, ...]) -> tuple[Any, Any]:
    """The SOTC core after its pure-loop run, and the run: the one ``loop_figures`` of the same
    configuration simulated (``comparison.loop_result`` caches it)."""
    return loop_result(SOTC, tuple((k, v) for k, v in json.loads(params)), stop_time, SUBSTEPS, perturbation)


@functools.lru_cache(maxsize=None)
def _sotc(params: str, stop_time: float, perturbation: tuple[float, ...]) -> str:
    ctrl, res = _sotc_run(params, stop_time, perturbation)
    flags = res.outputs[:, res.names.index("chi_a_bounded")] > 0.5
    active = res.t[flags]
    return _text(_plain({"W": list(ctrl.W), "swaps": ctrl.stack.swaps, "stack_count": ctrl.stack.count,
                         "min_eig": ctrl.stack.min_eig_at(list(ctrl.W)) if ctrl.stack.count else None,
                         "chi_a_bounded": int(flags.sum()), "chi_a_last": float(active[-1]) if len(active) else None}))


def sotc_figures(params: list[list[Any]], stop_time: float, perturbation: tuple[float, ...] = NOMINAL) -> Figures:
    """What the numerics tables print of an SOTC core's own state after a pure-loop run: the learned W, the CL
    stack's swaps, its size and lambda_min at W, and where the bound (5) holds chi_vd^a."""
    return json.loads(_sotc(json.dumps(params), stop_time, tuple(perturbation)))


@functools.lru_cache(maxsize=None)
def _value(params: str, stop_time: float, perturbation: tuple[float, ...]) -> str:
    from orchestration.study.value_function import value_rows

    ctrl, res = _sotc_run(params, stop_time, perturbation)
    return _text(_plain([{"label": r.label, "residuals": r.residuals, "state_cost": r.state_cost,
                          "omega_cost": r.omega_cost, "cost_earlier": r.cost_earlier}
                         for r in value_rows(np.array(ctrl.W), res)]))


def value_figures(params: list[list[Any]], stop_time: float, perturbation: tuple[float, ...] = NOMINAL) -> Figures:
    """The value-function measures (``orchestration.study.value_function.value_rows``) of the W an SOTC core
    learns in a pure-loop run, and of that run's visited states: {"rows": [the fields of each ValueRow]}."""
    return {"rows": json.loads(_value(json.dumps(params), stop_time, tuple(perturbation)))}


def value_rows_of(figures: Figures) -> list[Any]:
    """``value_figures``' rows as ``ValueRow``s."""
    from orchestration.study.value_function import ValueRow

    return [ValueRow(r["label"], tuple(r["residuals"]), *(np.array(r[k]) for k in ("state_cost", "omega_cost",
                                                                                    "cost_earlier")))
            for r in figures["rows"]]


FIGURES: dict[str, Callable[..., Figures]] = {"loop": loop_figures, "sotc": sotc_figures, "value": value_figures}
_collected: dict[str, list[Any]] | None = None  # key -> [kind, args] while ``collecting``
_stores: dict[Path, dict[str, Any]] = {}
_root = Path(__file__).resolve().parents[2]  # the checkout whose docs/ holds the store (``use``)


def key(kind: str, args: list[Any]) -> str:
    """The store's key of a configuration: the figures' kind and the arguments of its ``FIGURES`` function."""
    return _text([kind, *args])


def recompute(stored_key: str, index: int) -> Figures:
    """The figures of a stored configuration under ``PERTURBATIONS[index]``, computed now."""
    kind, *args = json.loads(stored_key)
    return FIGURES[kind](*args, PERTURBATIONS[index])


def _recompute_run(stored_keys: list[str], index: int) -> list[Figures]:
    """``recompute`` of configurations that read one run (``_run_of``), in one process: one simulation."""
    return [recompute(k, index) for k in stored_keys]


def _run_of(kind: str, args: list[Any]) -> str:
    """The pure-loop run a configuration's figures are read from: (core, parameters, stop time)."""
    return _text([args[0], *args[1:]] if kind == "loop" else [SOTC, *args])


def _figures(kind: str, args: list[Any], check: bool = True) -> tuple[Figures, list[Figures]]:
    """The figures of a configuration and of its perturbed runs; ``check``: its nominal run computed now and
    compared with the store (else read from the store, as a table of stored runs is)."""
    at = key(kind, args)
    if _collected is not None:
        nominal = FIGURES[kind](*args)
        _collected[at] = [kind, args]
        return nominal, [nominal] * len(PERTURBATIONS)
    entry = stored(_root).get(at)
    if entry is None:
        raise Stale(f"{STORE} has no perturbed runs of {at}")
    if not check:
        return entry["nominal"], entry["perturbed"]
    nominal = FIGURES[kind](*args)
    if _text(entry["nominal"]) != _text(nominal):
        raise Stale(f"the nominal run of {at} differs from the one stored in {STORE}")
    return nominal, entry["perturbed"]


def design(fmu: str, params: dict[str, float], stop_time: float = 100.0,
           check: bool = True) -> tuple[Figures, list[Figures]]:
    """The printed metrics of a controller core with these parameters from section 4's initial state, nominal
    and under every one of ``PERTURBATIONS`` (from the store; ``check``: as ``_figures``)."""
    return _figures("loop", [fmu, sorted([k, v] for k, v in params.items()), stop_time], check)


def metrics(scenario: str, stop_time: float = 100.0, **overrides: float) -> tuple[Figures, list[Figures]]:
    """``design`` of a scenario's controller (with overrides)."""
    return design(*controller_of(scenario, **overrides), stop_time)


def tuned(fmu: str, handling: int) -> tuple[Figures, list[Figures]]:
    """``metrics`` of ``fmu`` tuned under a handling (``comparison.tuned_run``)."""
    scenario, overrides = tuned_run(fmu, handling)
    return metrics(scenario, **overrides)


def sotc(setting: str, stop_time: float = 100.0, **overrides: float) -> tuple[Figures, list[Figures]]:
    """``sotc_figures`` of a setting's SOTC (with overrides), nominal and under every one of ``PERTURBATIONS``."""
    _, params = controller_of(setting, **overrides)
    return _figures("sotc", [sorted([k, v] for k, v in params.items()), stop_time])


def value(setting: str, stop_time: float = 100.0) -> tuple[Figures, list[Figures]]:
    """``value_figures`` of a setting's SOTC, nominal and under every one of ``PERTURBATIONS``."""
    _, params = controller_of(setting)
    return _figures("value", [sorted([k, v] for k, v in params.items()), stop_time])


def _perturbations() -> list[list[float]]:
    return [list(p) for p in PERTURBATIONS]


def use(root: Path) -> None:
    """Read and write the store of the checkout at ``root``."""
    global _root
    _root = root


def stored(root: Path) -> dict[str, Any]:
    """The store's runs (key -> {"nominal": figures, "perturbed": [figures per perturbation]})."""
    path = root / STORE
    if path not in _stores:
        data = json.loads(path.read_text()) if path.is_file() else {"perturbations": _perturbations(), "runs": {}}
        if data["perturbations"] != _perturbations():
            raise Stale(f"{STORE} holds other perturbations than comparison.PERTURBATIONS")
        _stores[path] = data["runs"]
    return _stores[path]


@contextlib.contextmanager
def collecting() -> Iterator[dict[str, list[Any]]]:
    """Within: every configuration whose perturbed figures a table asks for is collected (key -> [kind,
    args]), and the table gets its nominal figures in their place."""
    global _collected
    _collected = {}
    try:
        yield _collected
    finally:
        _collected = None




def compute(configurations: dict[str, list[Any]], keep_others: bool, workers: int = 2) -> int:
    """Run every configuration under every perturbation on ``workers`` processes (progress on stdout) and
    store them with their nominal figures; the configurations stored before are kept if ``keep_others``.
    Returns the number of runs."""
    runs = dict(stored(_root)) if keep_others else {}
    groups: dict[str, list[str]] = {}
    for at, (kind, args) in configurations.items():
        groups.setdefault(_run_of(kind, args), []).append(at)
    jobs = [(keys, i) for keys in groups.values() for i in range(len(PERTURBATIONS))]
    results: dict[tuple[str, int], Figures] = {}
    progress = Progress(len(jobs), "perturbed runs", workers)
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = {pool.submit(_recompute_run, *job): job for job in jobs}
        for future in as_completed(futures):
            keys, i = futures[future]
            results.update({(at, i): figures for at, figures in zip(keys, future.result())})
            progress.update(True)
    progress.close()
    for key, (kind, args) in configurations.items():
        runs[key] = {"nominal": FIGURES[kind](*args),
                     "perturbed": [results[key, i] for i in range(len(PERTURBATIONS))]}
    data = {"perturbations": _perturbations(), "runs": runs}
    atomic_write(_root / STORE, json.dumps(data, indent=1, sort_keys=True) + "\n")
    _stores[_root / STORE] = runs
    return len(jobs)
