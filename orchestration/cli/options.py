"""Argument types and options shared by the ``sotc-cosim`` subcommands."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from orchestration.exit_codes import UsageError
from orchestration.paths import DEFAULT_FMU_DIR, FMI_VERSIONS, fmu_folder
from orchestration.recording import live
from orchestration.run.scenario import MAX_STEPS

DEFAULT_SCENARIO = "paper"


def _whole(text: str, low: int) -> int:
    try:
        value = int(text)
    except ValueError:
        value = low - 1
    if not low <= value <= MAX_STEPS:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number from {low} to {MAX_STEPS}")
    return value


def positive_int(text: str) -> int:
    """A whole number from 1 to MAX_STEPS (the most steps a run may have: no count here needs more)."""
    return _whole(text, 1)


def non_negative_int(text: str) -> int:
    """A whole number from 0 to MAX_STEPS."""
    return _whole(text, 0)


def seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number of seconds > 0")
    return value


def stop_times(text: str) -> list[float]:
    if text.strip().lower() == "none":
        return []
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected stop times like 1000,10000 or 'none', got {text!r}") from None
    if not all(v > 0 for v in values):
        raise argparse.ArgumentTypeError(f"stop times must be > 0, got {text!r}")
    return values


def add_fmu_dir(p: argparse.ArgumentParser) -> None:
    p.add_argument("--fmu-dir", type=Path, default=DEFAULT_FMU_DIR, help="where FMUs are built and found")


def add_fmi(p: argparse.ArgumentParser, what: str = "run") -> None:
    p.add_argument("--fmi", type=int, choices=FMI_VERSIONS, default=2,
                   help=f"{what} the FMI 2.0 FMUs (default) or the FMI 3.0 ones, built from the same sources "
                        f"(default folder {fmu_folder(DEFAULT_FMU_DIR, 3)} for FMI 3)")


def fmu_dir_of(args: argparse.Namespace) -> Path:
    """``--fmu-dir`` as given, else the default folder of the ``--fmi`` version asked for."""
    return fmu_folder(args.fmu_dir, getattr(args, "fmi", 2), given=args.fmu_dir is not DEFAULT_FMU_DIR)


def add_force(p: argparse.ArgumentParser, kinds: str) -> None:
    p.add_argument("--force", action="store_true",
                   help=f"replace an existing output file that is not {kinds} (refused without it)")


def add_stop_time(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--stop-time", type=seconds, help=help)


class _SchedulerAddress(argparse.Action):
    """``--scheduler``: its form checked while the command line is read, before anything is built,
    created or printed (one that cannot be reached is found when the command connects)."""

    def __call__(self, parser, namespace, values, option_string=None):
        from orchestration.sweep.addresses import check_scheduler_address

        try:
            setattr(namespace, self.dest, check_scheduler_address(values))
        except ValueError as exc:
            parser.error(str(exc))


def add_cluster(p: argparse.ArgumentParser, scheduler_note: str = "") -> None:
    """``--workers`` or ``--scheduler`` (one of the two), the same in every command that runs on Dask
    (``orchestration.sweep.cluster``)."""
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=positive_int,
                       help="worker processes of the local Dask cluster (default: one per core)")
    where.add_argument("--scheduler", action=_SchedulerAddress, metavar="ADDRESS",
                       help=f"an existing dask.distributed scheduler, tcp://host:8786{scheduler_note} "
                            "(default: a local cluster)")


def _rerun_url(text: str) -> str:
    try:
        return live.check_url(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_live(p: argparse.ArgumentParser) -> None:
    """Rerun's script options for watching the recording live (``rerun.script_add_args``), beside the
    file, which is written as without them (``orchestration.recording.live``); ``live_of`` reads them."""
    g = p.add_argument_group("watching live (Rerun's script options; the recording file is written either way)")
    g.add_argument("--connect", action="store_true", help="also stream to a running Rerun viewer (start one with `rerun`)")
    g.add_argument("--url", type=_rerun_url, help=f"the viewer --connect streams to (default {live.DEFAULT_URL})")
    g.add_argument("--serve", action="store_true",
                   help=f"also host a gRPC server (port {live.GRPC_PORT}) and a web viewer (http://127.0.0.1:{live.WEB_PORT})")


def live_of(args: argparse.Namespace) -> live.Live | None:
    """What ``add_live``'s options ask for (None: the file only, also for a command without them)."""
    if getattr(args, "url", None) and not args.connect:
        raise UsageError("--url is the viewer of --connect: give both")
    return live.of_arguments(getattr(args, "connect", False), getattr(args, "url", None), getattr(args, "serve", False))
