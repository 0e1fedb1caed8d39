"""Sweep files: a base scenario, axes over its settings, and how the axes combine into points.

A sweep file is TOML (``orchestration/sweep/presets/<name>.toml``, shipped as package data, or any path)::

    name = "robustness"
    description = "..."
    scenario = "paper-perturbed"    # base scenario: a shipped name or a .toml path (relative to this file)
    stop_time = 20.0                # optional: overrides the base scenario's stop time, s
    combine = "grid"                # grid | paired | one-at-a-time
    seed = 12                       # seeds every random axis (default 0)
    time_limit = 300.0              # wall-clock seconds one point may take (default 600)
    state_bound = 1000.0            # |phi| (rad) or |dphi| (rad/s) beyond this is divergence (default 1000)
    set = { "controller.limit_handling" = 0 }   # applied to every point, after the axes

    [controller_settings.LqrController]   # applied only to points whose controller is this FMU, after `set`
    tuning = "best"                 # optional: the best point of this FMU's tuning search (below)
    tuning_seed = 1                 # optional, with tuning: the best of this tuning seed (default: the first)
    "controller.r" = 0.1            # instance.parameter = number, like `set`

    [controller_settings."SOTC, learning off"]   # a named entry: a controller axis value of its own
    fmu = "SotcController"          # the FMU it runs
    tuning = "best"
    learning = false                # the critic frozen (alpha1 = alpha2 = 1e-9), after the tuning

    [[axis]]
    name = "plant.p1"               # instance.parameter, or a setting: controller, step_size, stop_time
    values = [0.8, 1.0, 1.2]        # a list; or
    # range = { start = 0.8, stop = 1.2, num = 5 }        (both ends included)
    # random = { distribution = "uniform", low = 0.8, high = 1.2, count = 6 }
    #          distributions: uniform (low, high), normal (mean, std), loguniform (low, high), choice (values)
    scale = true                    # the values multiply the base scenario's value (e.g. +/-20 % model error)
    group = "initial state"         # axes of one group vary together (paired): one axis of the combination

Combination over the groups (an axis without ``group`` is a group of its own): ``grid`` is the
cartesian product in file order (the last axis varies fastest), ``paired`` takes the i-th value of
every group (equal lengths), ``one-at-a-time`` varies each group alone with the others at the base
scenario's values. A ``controller`` axis names controller FMUs (model identifiers), or files relative to
this file: a controller file (``mine.toml``: ``fmu``, ``ports``, ``parameters``;
``orchestration.run.scenario``) or an ``.fmu`` file, a controller from any tool held to the contract
(docs/benchmark.md); the controller instance keeps the base scenario's parameters only for the same FMU; ``controller_settings`` gives a
controller FMU its own parameters (a fair comparison tunes each baseline, not only the base scenario's
controller); a table with ``fmu = "<FMU>"`` is a named entry (any label) that a ``controller`` axis lists
like an FMU, so one FMU can run twice, e.g. with and without learning, paired on the same points.
``tuning = "best"`` takes them from the one tuning protocol every controller gets,
``orchestration.study.tuning`` (the same budget for the SOTC, CT, LQR and the OTC; the stored best
point of one tuning seed, ``tuning_seed`` or the first, on the tuning's training set) under the point's
own ``controller.limit_handling``: the tuning the results table reports (README, docs/results.md).
The parameters a point gets this way are part of its settings (and of its resume key). Random axes
draw from ``numpy.random.default_rng([seed, axis number])``: the same file and seed give the same points.

Every value is checked before anything runs, the file's shape by a JSON schema
(``orchestration.sweep.schema``: a non-numeric or non-finite value, an unknown key, a missing one),
then what depends on the base scenario and the stored tuning; each refusal is one line naming the
file, the axis or key and what is allowed. Nothing here knows Dask or fmpy:
``orchestration.sweep.runner`` runs the points.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from fmu_controller.base import RENAMED_PARAMETERS
from fmu_controller.catalog import CORES
from orchestration.run.scenario import Instance, Scenario, ScenarioError, controller_instance, is_file, load_scenario
from orchestration.sweep.schema import DISTRIBUTIONS, MAX_POINTS, check_sweep_schema
from orchestration.toml_files import parse_toml, read_toml, unknown_file

SETTINGS = ("controller", "step_size", "stop_time")  # axes that are not FMU parameters
DEFAULT_TIME_LIMIT = 600.0
DEFAULT_STATE_BOUND = 1000.0


class SweepError(ScenarioError):
    """A sweep file that cannot be run as written; the message names the file and the axis."""


@dataclass(frozen=True)
class Axis:
    name: str  # "instance.parameter" or a SETTINGS entry
    values: tuple[Any, ...]  # floats, or model identifiers for "controller"
    scale: bool = False
    group: str = ""

    @property
    def label(self) -> str:
        return f"{self.name} [x base]" if self.scale else self.name


@dataclass(frozen=True)
class ControllerSettings:
    """``[controller_settings.<label>]``: parameters for the points whose controller axis value is the
    label (an FMU's model identifier, or a named entry that runs ``fmu``)."""
    fmu: str
    values: dict[str, float]  # instance.parameter -> value
    tuning: str = ""  # "best": the parameters of the best point of the FMU's tuning search
    learning: bool = True  # False: alpha1 = alpha2 = 1e-9 after everything else (the SOTC's critic frozen)
    tuning_seed: int | None = None  # the tuning seed whose best point ``tuning = "best"`` takes (None: the first)

    def parameters(self, scenario: Scenario) -> dict[str, float]:
        """What this applies to a point's scenario (whose controller is ``fmu``): the tuned parameters
        under the scenario's limit handling, then the explicit values."""
        out: dict[str, float] = {}
        if self.tuning == "best":
            from orchestration.study.comparison import handling_code
            from orchestration.study.tuning import tuned_parameters

            params = {**scenario.instances["controller"].parameters,
                      **{k.partition(".")[2]: v for k, v in self.values.items() if k.startswith("controller.")}}
            tuned = tuned_parameters(self.fmu, handling_code(self.fmu, params), self.tuning_seed)
            out = {f"controller.{k}": v for k, v in tuned.items()}
        out.update(self.values)
        if not self.learning:
            from orchestration.study.sotc_study import NO_LEARNING

            out.update({f"controller.{k}": v for k, v in NO_LEARNING.items()})
        return out


@dataclass(frozen=True)
class Point:
    index: int
    # axis label -> value as written in the file (a factor for scaled axes), then the parameters the
    # point's [controller_settings.<fmu>] gave it (instance.parameter -> value)
    settings: dict[str, Any]
    scenario: Scenario


@dataclass(frozen=True)
class Sweep:
    name: str
    description: str
    base: Scenario
    axes: tuple[Axis, ...]
    combine: str
    seed: int
    time_limit: float
    state_bound: float
    fixed: dict[str, float]
    per_controller: dict[str, ControllerSettings] = dataclasses.field(default_factory=dict)
    # a controller axis value that is a file (a controller file or an FMU file): the controller it runs
    files: dict[str, Instance] = dataclasses.field(default_factory=dict)

    def groups(self) -> dict[str, list[Axis]]:
        """The axes of the combination: group name (an ungrouped axis: its own name) -> its axes."""
        groups: dict[str, list[Axis]] = {}
        for axis in self.axes:
            groups.setdefault(axis.group or axis.name, []).append(axis)
        return groups

    def points(self) -> list[Point]:
        members = list(self.groups().values())
        rows = [list(zip(*(a.values for a in axes))) for axes in members]  # per group: value tuples
        if self.combine == "grid":
            combos = [[(m, v) for m, v in zip(members, combo)] for combo in itertools.product(*rows)]
        elif self.combine == "paired":
            combos = [[(m, r[i]) for m, r in zip(members, rows)] for i in range(len(rows[0]) if rows else 1)]
        else:  # one-at-a-time
            combos = [[(m, v)] for m, r in zip(members, rows) for v in r] or [[]]
        points = []
        for i, combo in enumerate(combos):
            settings = {a.label: v for axes, values in combo for a, v in zip(axes, values)}
            applied = [(a, v) for axes, values in combo for a, v in zip(axes, values)]
            scenario = self._apply(applied, f"{self.name}#{i}")
            own = self.per_controller.get(settings.get("controller", scenario.controller_fmu() or ""))
            extra = own.parameters(scenario) if own else {}
            points.append(Point(i, {**settings, **extra}, scenario.with_parameters(extra) if extra else scenario))
        return points

    def controller_parameters(self) -> dict[str, list[dict[str, Any]]]:
        """Per label of ``controller_settings``: the distinct parameter sets its points get (one, unless
        ``tuning = "best"`` meets points of different limit handlings)."""
        labels = {a.label for a in self.axes}
        out: dict[str, list[dict[str, Any]]] = {fmu: [] for fmu in self.per_controller}
        for p in self.points():
            seen = out.get(p.settings.get("controller", p.scenario.controller_fmu() or ""))
            extra = {k: v for k, v in p.settings.items() if k not in labels}
            if seen is not None and extra not in seen:
                seen.append(extra)
        return out

    def _apply(self, applied: list[tuple[Axis, Any]], name: str) -> Scenario:
        sc = self.base
        for axis, value in sorted(applied, key=lambda av: av[0].name != "controller"):  # controller first
            if axis.name == "controller":
                old, fmu = sc.instances["controller"], self.fmu_of(value)
                new = self.files.get(value) or Instance("controller", fmu, old.parameters if fmu == old.fmu else {})
                sc = dataclasses.replace(sc, instances={**sc.instances, "controller": new})
        params: dict[str, float] = {}
        for axis, value in applied:
            if axis.name == "step_size":
                sc = sc.with_step_size(value)
            elif axis.name == "stop_time":
                sc = sc.with_stop_time(value)
            elif axis.name != "controller":
                params[axis.name] = value * _base_value(self.base, axis) if axis.scale else value
        return sc.with_parameters({**params, **self.fixed}, name=name)

    def model_names(self) -> list[str]:
        """Every FMU model identifier a point of this sweep may load."""
        models = {i.fmu for i in self.base.instances.values()}
        models |= {self.fmu_of(v) for a in self.axes if a.name == "controller" for v in a.values}
        return sorted(models)

    def fmu_of(self, controller: str) -> str:
        """The FMU a controller axis value runs (a named entry's ``fmu``, a file's FMU, else the value itself)."""
        own = self.per_controller.get(controller)
        return own.fmu if own else (self.files[controller].fmu if controller in self.files else controller)


def _base_value(base: Scenario, axis: Axis) -> float:
    inst, _, pname = axis.name.partition(".")
    return float(base.instances[inst].parameters[pname])


def available_sweeps() -> list[str]:
    folder = resources.files("orchestration.sweep.presets")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def grid_from_assignments(scenario: str, items: list[str]) -> Sweep:
    """The sweep of ``sotc-cosim sweep SCENARIO --set inst.param=v1,v2 [--set ...]``: a grid over
    the given values of the scenario (a name or a .toml path)."""
    axes = []
    for item in items:
        key, sep, values = item.partition("=")
        if not sep or not key.strip() or not values:
            raise SweepError(f"--set {item!r}: write instance.parameter=v1,v2,...")
        try:
            numbers = [float(v) for v in values.split(",")]
        except ValueError:
            raise SweepError(f"--set {item!r}: every value must be a number") from None
        axes.append({"name": key.strip(), "values": numbers})
    name = f"{Path(scenario).stem}-sweep"
    return parse_sweep({"name": name, "scenario": scenario, "axis": axes}, f"{scenario} --set", Path.cwd())


def load_sweep(name_or_path: str) -> Sweep:
    path = Path(name_or_path)
    if path.suffix == ".toml" and path.is_file():
        label, folder = str(path), path.resolve().parent
        raw = read_toml(path, f"sweep '{label}'", SweepError)
    else:
        resource = resources.files("orchestration.sweep.presets") / f"{name_or_path}.toml"
        if not resource.is_file():
            raise unknown_file(name_or_path, "sweep", available_sweeps(), SweepError)
        label, folder = name_or_path, None
        raw = parse_toml(resource.read_bytes(), f"sweep '{label}'", SweepError)
    return parse_sweep(raw, label, folder, default_name=path.stem)


def parse_sweep(raw: dict[str, Any], label: str, folder: Path | None = None, default_name: str = "sweep") -> Sweep:
    """Validate a parsed sweep file completely (nothing has run yet) and return it."""
    where = f"sweep '{label}'"
    check_sweep_schema(raw, where, SweepError)
    scenario_ref = raw["scenario"]
    if folder is not None and scenario_ref.endswith(".toml") and not Path(scenario_ref).is_absolute():
        scenario_ref = str(folder / scenario_ref)
    base = load_scenario(scenario_ref)
    if "stop_time" in raw:
        base = base.with_stop_time(float(raw["stop_time"]))
    seed = raw.get("seed", 0)
    fixed = {k: float(v) for k, v in raw.get("set", {}).items()}
    for key in fixed:
        _check_parameter_name(base, key, f'{where}: set."{key}"')
    axes = tuple(_parse_axis(spec, i, seed, base, where) for i, spec in enumerate(raw.get("axis", [])))
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise SweepError(f"{where}: an axis is given twice: {sorted({n for n in names if names.count(n) > 1})}")
    per_controller = _controller_settings(raw.get("controller_settings", {}), base, axes, where)
    sweep = Sweep(
        name=raw.get("name", default_name), description=raw.get("description", ""), base=base, axes=axes,
        combine=raw.get("combine", "grid"), seed=seed, time_limit=float(raw.get("time_limit", DEFAULT_TIME_LIMIT)),
        state_bound=float(raw.get("state_bound", DEFAULT_STATE_BOUND)), fixed=fixed, per_controller=per_controller,
        files=_controller_files(axes, folder, where),
    )
    _check_shape(sweep, where)
    sweep.points()  # every point's scenario is valid (whole number of steps, known instances)
    return sweep


def _controller_files(axes: tuple[Axis, ...], folder: Path | None, where: str) -> dict[str, Instance]:
    """Each controller axis value that is a file, relative to the sweep file's folder (None: a shipped sweep, which
    names our controllers only): the controller instance it describes (``scenario.controller_instance``)."""
    out = {}
    for value in (v for a in axes if a.name == "controller" for v in a.values if is_file(v)):
        here = f"{where}: axis 'controller': {value}"
        if folder is None:
            raise SweepError(f"{here}: a shipped sweep names our controllers, not files")
        out[value] = controller_instance(folder / Path(value).expanduser(), here, SweepError)
    return out


def _controller_settings(raw: dict[str, Any], base: Scenario, axes: tuple[Axis, ...],
                         where: str) -> dict[str, ControllerSettings]:
    """``[controller_settings.<label>]`` tables (their shape checked by the schema): each one a controller
    the sweep runs, no parameter that an axis varies or that the tuning search sets too."""
    from orchestration.study.tuning import CONTROLLERS, tuned_parameter_names

    axis_fmus = [v for a in axes if a.name == "controller" for v in a.values]  # else: the base's controller
    runs = sorted(set(axis_fmus)) if axis_fmus else [f for f in [base.controller_fmu()] if f]
    swept = {a.name for a in axes}
    out = {}
    for label, table in raw.items():
        here = f"{where}: controller_settings.{label}"
        if label not in runs:
            raise SweepError(f"{here}: no point of this sweep runs controller {label!r}; its controllers: "
                             f"{', '.join(runs) or 'none'}")
        if is_file(label):
            raise SweepError(f"{here}: a controller file sets its parameters in its own file (parameters = {{ ... }})")
        fmu, tuning, learning = table.get("fmu", label), table.get("tuning", ""), table.get("learning", True)
        if fmu not in CORES:
            raise SweepError(f"{here}.fmu = {fmu!r}; choose a controller FMU: {', '.join(CORES)}")
        values = {k: float(v) for k, v in table.items() if k not in ("tuning", "fmu", "learning", "tuning_seed")}
        tuning_seed = _tuning_seed(table, tuning, here)
        tuned = {f"controller.{p}" for p in tuned_parameter_names(fmu)}
        if tuning and not tuned:
            raise SweepError(f"{here}.tuning: {fmu} has no tuning search (orchestration.study.tuning tunes "
                             f"{', '.join(CONTROLLERS)}); give its parameters instead")
        specs = {s.name: s for s in CORES[fmu].PARAMETER_SPECS}
        if not learning and not {"alpha1", "alpha2"} <= set(specs):
            raise SweepError(f"{here}.learning = {learning!r}: true, or false for a controller with critic rates "
                             "alpha1, alpha2 (the SotcController)")
        for key, value in values.items():
            at = f'{here}."{key}"'
            _check_parameter_name(base, key, at)
            if key in swept:
                raise SweepError(f"{at}: an axis varies {key} already")
            if tuning and key in tuned:
                raise SweepError(f"{at}: tuning = {tuning!r} sets {key} already")
            inst, _, pname = key.partition(".")
            if inst == "controller":
                _check_controller_parameter(fmu, specs, pname, value, at)
        out[label] = ControllerSettings(fmu, values, tuning, learning, tuning_seed)
    return out


def _check_controller_parameter(fmu: str, specs: dict[str, Any], pname: str, value: float, at: str) -> None:
    if pname not in specs:
        renamed = (f" ({pname!r} was renamed {RENAMED_PARAMETERS[pname]!r} in 0.2.0, see CHANGELOG.md)"
                   if pname in RENAMED_PARAMETERS else "")
        raise SweepError(f"{at}: {fmu} has no parameter {pname!r}{renamed}; its parameters: {', '.join(specs)}")
    try:
        specs[pname].check(value)
    except ValueError as exc:
        raise SweepError(f"{at}: {exc}") from None


def _tuning_seed(table: dict[str, Any], tuning: str, here: str) -> int | None:
    """``tuning_seed``: one of the stored search's seeds, with ``tuning = "best"`` only."""
    if "tuning_seed" not in table:
        return None
    from orchestration.study.tuning import stored

    seeds, value = stored()["seeds"], table["tuning_seed"]
    if not tuning or value not in seeds:
        raise SweepError(f"{here}.tuning_seed = {value!r}: with tuning = \"best\", one of the stored tuning seeds "
                         f"{', '.join(map(str, seeds))}")
    return int(value)


def _check_shape(sweep: Sweep, where: str) -> None:
    groups = sweep.groups()
    for group, axes in groups.items():
        if len({len(a.values) for a in axes}) > 1:
            raise SweepError(f"{where}: the axes of group '{group}' must have as many values each: "
                             + ", ".join(f"{a.name} has {len(a.values)}" for a in axes))
    sizes = [len(axes[0].values) for axes in groups.values()]
    if sweep.combine == "paired" and len(set(sizes)) > 1:
        raise SweepError(f"{where}: combine = 'paired' needs axes of equal length, got "
                         + ", ".join(f"{g}: {n}" for g, n in zip(groups, sizes)))
    total = math.prod(sizes) if sweep.combine == "grid" else (sum(sizes) if sweep.combine == "one-at-a-time" else max(sizes, default=1))
    if total > MAX_POINTS:
        raise SweepError(f"{where}: {total} points; at most {MAX_POINTS} per sweep")


def _parse_axis(spec: dict[str, Any], number: int, seed: int, base: Scenario, where: str) -> Axis:
    """One ``[[axis]]`` (its shape checked by the schema): its values, checked against the base scenario."""
    name, scale = spec["name"], spec.get("scale", False)
    here = f"{where}: axis '{name}'"
    kinds = [k for k in ("values", "range", "random") if k in spec]
    if len(kinds) != 1 or (name == "controller" and kinds != ["values"]):
        raise SweepError(f"{here}: give exactly one of values, range or random (values for a controller axis)")
    if name not in SETTINGS:
        _check_parameter_name(base, name, here)
        if scale and name.partition(".")[2] not in base.instances[name.partition(".")[0]].parameters:
            raise SweepError(f"{here}: scale = true multiplies the base scenario's value, but it does not set {name}")
    elif scale:
        raise SweepError(f"{here}: scale applies to FMU parameters only")
    if name == "controller":
        values: tuple[Any, ...] = tuple(spec["values"])
    elif kinds == ["values"]:
        values = tuple(float(v) for v in spec["values"])
    elif kinds == ["range"]:
        r = spec["range"]
        values = tuple(float(v) for v in np.linspace(r["start"], r["stop"], r["num"]))
    else:
        values = _random(spec["random"], np.random.default_rng([seed, number]), here)
    return Axis(name, values, scale, spec.get("group", ""))


def _check_parameter_name(base: Scenario, name: str, here: str) -> None:
    inst, _, pname = name.partition(".")
    if inst not in base.instances or not pname:
        raise SweepError(f"{here}: write instance.parameter with an instance of the base scenario "
                         f"({', '.join(sorted(base.instances))}) or a setting ({', '.join(SETTINGS)})")


def _random(spec: dict[str, Any], rng: np.random.Generator, here: str) -> tuple[float, ...]:
    """``count`` draws of ``distribution`` (its keys checked by the schema)."""
    dist, count = spec["distribution"], spec["count"]
    if dist == "choice":
        return tuple(float(v) for v in rng.choice([float(v) for v in spec["values"]], size=count))
    a, b = (float(spec[k]) for k in DISTRIBUTIONS[dist])
    if dist == "normal":
        return tuple(float(v) for v in rng.normal(a, b, count))
    if not a < b or (dist == "loguniform" and a <= 0):
        raise SweepError(f"{here}: random needs 0 < low < high (loguniform) or low < high, got {a:g}, {b:g}")
    if dist == "loguniform":
        return tuple(float(v) for v in np.exp(rng.uniform(math.log(a), math.log(b), count)))
    return tuple(float(v) for v in rng.uniform(a, b, count))
