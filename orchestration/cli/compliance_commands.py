"""``sotc-cosim validate``, ``cross-check`` and ``export-ssp``: FMI compliance and other tools."""
from __future__ import annotations

import argparse
from pathlib import Path

from orchestration import exit_codes
from orchestration.cli.options import (DEFAULT_SCENARIO, add_fmi, add_fmu_dir, add_force, add_stop_time, fmu_dir_of,
                                       seconds)
from orchestration.exit_codes import UsageError
from orchestration.paths import check_output_file, check_output_folder
from orchestration.run import interrupt
from orchestration.run.scenario import load_scenario


# why export-ssp --fmi 3 writes nothing (measured with fmpy 0.3.32; docs/interop.md)
NO_SSP2 = ("export-ssp --fmi 3: no SSP 2.0 archive is written, because fmpy.ssp (0.3.32) reads only the "
           "SSP 1.x namespaces and its simulate_ssp instantiates every component as FMI 2.0, so it could "
           "neither read nor run one; export the FMI 2.0 FMUs (export-ssp without --fmi 3)")


def _fmu_files(names: list[str], fmu_dir: Path, fmi: int = 2) -> list[Path]:
    """Model names (built if missing) or paths to .fmu files; none: every FMU of FMU_SOURCES."""
    from orchestration.fmu_build.build import FMU_SOURCES, ensure_built
    from orchestration.fmu_build.child import BuildError

    names = names or list(FMU_SOURCES)
    unknown = [n for n in names if n not in FMU_SOURCES and not Path(n).is_file()]
    if unknown:
        raise BuildError(f"no FMU {unknown}: give a model ({', '.join(FMU_SOURCES)}) or a .fmu path")
    interrupt.check_before_work()
    built = ensure_built([n for n in names if n in FMU_SOURCES], fmu_dir, fmi)
    return [built[n] if n in FMU_SOURCES else Path(n) for n in names]


def _cmd_validate(args: argparse.Namespace) -> int:
    from orchestration.compliance.validate import format_report, validate_fmus

    report = validate_fmus(_fmu_files(args.fmus, fmu_dir_of(args), args.fmi))
    print(format_report(report))
    return exit_codes.OK if report.ok else exit_codes.FAILED


def _cmd_cross_check(args: argparse.Namespace) -> int:
    from orchestration.compliance.cross_check import SOURCE_SCENARIO, generate
    from orchestration.fmu_build.build import FMU_SOURCES, ensure_built

    check_output_folder(args.out, "--out")
    models = args.models or list(FMU_SOURCES)
    loop = sorted({i.fmu for i in load_scenario(SOURCE_SCENARIO).instances.values()})
    interrupt.check_before_work()
    paths = ensure_built(sorted(set(models) | set(loop)), fmu_dir_of(args), args.fmi)
    for folder in generate(args.out, paths, stop_time=args.stop_time, models=models):
        print(folder)
    return exit_codes.OK


def _cmd_export_ssp(args: argparse.Namespace) -> int:
    from orchestration.compliance.ssp import ARCHIVE, export_ssp
    from orchestration.fmu_build.build import ensure_built

    if args.fmi == 3:
        raise UsageError(NO_SSP2)
    check_output_file(args.out, "--out", kind=ARCHIVE, force=args.force)
    scenario = load_scenario(args.scenario)
    if args.stop_time is not None:
        scenario = scenario.with_stop_time(args.stop_time)
    interrupt.check_before_work()
    paths = ensure_built(sorted({i.fmu for i in scenario.instances.values()}), args.fmu_dir)
    print(export_ssp(scenario, paths, args.out))
    return exit_codes.OK


def _cmd_check_controller(args: argparse.Namespace) -> int:
    from orchestration.compliance.contract import check, read_ports, report
    from orchestration.compliance.validate import fmpy_problems

    ports, parameters, search = read_ports(args.ports) if args.ports is not None else (None, None, None)
    result = check(args.fmu, ports, parameters, search)
    result.problems += [f"fmpy: {p}" for p in fmpy_problems(args.fmu)]
    print(report(result))
    if result.problems:
        return exit_codes.FAILED
    return exit_codes.OK if args.no_run else _smoke_run(result, fmu_dir_of(args))


def _smoke_run(result, fmu_dir: Path) -> int:
    """check-controller's 1 s run against our arm, once the interface meets the contract."""
    from orchestration.compliance.smoke import STOP_TIME, models, scenario_for, smoke
    from orchestration.fmu_build.build import ensure_built

    interrupt.check_before_work()
    found = smoke(result, ensure_built(models(scenario_for(result)), fmu_dir))
    print("\n".join(found.lines))
    if found.interrupted:
        return interrupt.exit_code()
    print(f"  passes the {STOP_TIME:g} s run" if found.ok else f"  fails the {STOP_TIME:g} s run")
    return exit_codes.OK if found.ok else exit_codes.FAILED


def add_commands(sub) -> None:
    """validate, check-controller, cross-check, export-ssp."""
    p = sub.add_parser("validate", help="check FMUs: fmpy, fmutool -check and the project's invariants")
    p.add_argument("fmus", nargs="*", metavar="FMU", help="model names or .fmu paths (default: every FMU)")
    add_fmu_dir(p)
    add_fmi(p, "check (model names)")
    p.set_defaults(func=_cmd_validate)

    p = sub.add_parser("check-controller", help="check a controller FMU from any tool against the controller contract "
                       "(docs/benchmark.md): its port map, causalities, types, units, binary; fmpy's validation; "
                       "then a 1 s run against our arm")
    p.add_argument("fmu", type=Path, metavar="FMU", help="the controller's .fmu file (FMI 2.0 or 3.0 Co-Simulation)")
    p.add_argument("--ports", type=Path, metavar="TOML", help="a file with ports = { contract name = \"FMU variable\" "
                   "} and, if set, parameters = { name = value } and a [search] table, checked against the FMU (default: the FMU's "
                   "variables of the contract's names)")
    p.add_argument("--no-run", action="store_true", help="check the interface only: no 1 s run against our arm "
                   "(which runs the FMU in a process of its own and builds our arm where missing)")
    add_fmu_dir(p)
    p.set_defaults(func=_cmd_check_controller)

    p = sub.add_parser("cross-check", help="write a reference run of every FMU in the FMI Cross-Check layout")
    p.add_argument("models", nargs="*", metavar="MODEL", help="FMUs to export (default all)")
    p.add_argument("--out", type=Path, required=True, help="folder that receives fmus/2.0/cs/<platform>/... "
                   "(fmus/3.0/... with --fmi 3)")
    p.add_argument("--stop-time", type=seconds, default=5.0, help="length of each reference run, s (default 5)")
    add_fmu_dir(p)
    add_fmi(p, "export")
    p.set_defaults(func=_cmd_cross_check)

    p = sub.add_parser("export-ssp", help="write a scenario (FMUs, connections, parameters) as an SSP 1.0 archive")
    p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO, metavar="SCENARIO",
                   help=f"scenario name or .toml path (default {DEFAULT_SCENARIO})")
    p.add_argument("--out", type=Path, required=True, help="the .ssp file to write")
    add_force(p, "an SSP archive")
    add_stop_time(p, "override the scenario's stop time, s")
    add_fmu_dir(p)
    add_fmi(p, "export (FMI 3: refused, SSP 2.0 cannot be checked here; see docs/interop.md)")
    p.set_defaults(func=_cmd_export_ssp)
