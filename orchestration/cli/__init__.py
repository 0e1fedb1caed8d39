"""``sotc-cosim``: build the FMUs, run scenarios, and report.

One module per group of subcommands (``run_commands``, ``batch_commands``, ``compliance_commands``,
``optimum_commands``, ``tune_commands``, ``benchmark_commands``, ``cache_commands``), each adding its parsers; ``options`` holds the argument types
and the options they share.

This module imports only the standard library and light modules at its top: ``main`` defers SIGINT,
SIGTERM and SIGHUP before anything heavy is imported (under load the imports took 8 s, and a signal
then killed the command silently, exit -15)."""
from __future__ import annotations

import argparse
import os
import sys

from fmi_slave import VERSION
from orchestration import exit_codes
from orchestration.exit_codes import UsageError
from orchestration.run import interrupt
from orchestration.threads import one_blas_thread


def _command_groups() -> tuple:
    from orchestration.cli import (batch_commands, benchmark_commands, cache_commands, compliance_commands,
                                   optimum_commands, run_commands, tune_commands)

    return (run_commands, batch_commands, compliance_commands, optimum_commands, tune_commands, benchmark_commands,
            cache_commands)


class _Parser(argparse.ArgumentParser):
    """argparse with its usage errors on one line (the usage itself is one ``-h`` away). The command is
    checked after the other arguments: ``sotc-cosim --bogus`` names ``--bogus`` (argparse checked the
    missing command first and said only that)."""

    def error(self, message: str):
        self.exit(exit_codes.USAGE, f"{self.prog}: error: {message} (see {self.prog} -h)\n")

    def parse_known_args(self, args=None, namespace=None):
        self.given = list(sys.argv[1:] if args is None else args)  # what ``_VersionAlone`` looks at
        return super().parse_known_args(args, namespace)

    def parse_args(self, args=None, namespace=None):
        parsed = super().parse_args(args, namespace)  # an unknown argument is refused here, by name
        if getattr(parsed, "command", "") is None:
            self.error("the following arguments are required: command")
        return parsed


class _VersionAlone(argparse._VersionAction):
    """``--version`` prints the version only when it is the only argument (``--version extra`` exited 0)."""

    def __call__(self, parser, namespace, values, option_string=None):
        others = [a for a in getattr(parser, "given", []) if a != option_string]
        if others:
            parser.error(f"{option_string} takes no other arguments (got {' '.join(others)})")
        super().__call__(parser, namespace, values, option_string)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="sotc-cosim", description=__doc__.split("\n")[0].replace("``", ""))  # no reST markup
    parser.add_argument("--version", action=_VersionAlone, version=f"%(prog)s {VERSION}")
    sub = parser.add_subparsers(dest="command")  # required, checked by _Parser.parse_args after the rest
    for group in _command_groups():
        group.add_commands(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    stopped = "stopped between two steps; finished results were kept"
    with interrupt.signals_deferred():  # first: a signal during the imports below is noted, not fatal
        from orchestration.verified import limit
        from orchestration.fmu_build.child import BuildError, BuildInterrupted
        from orchestration.outputs import OutputError
        from orchestration.paths import check_output_folder
        from orchestration.cli.options import live_of
        from orchestration.recording import live

        args = build_parser().parse_args(argv)
        try:
            interrupt.check_before_work()  # a signal during the imports above: nothing starts
            limit()  # SOTC_COSIM_CACHE_LIMIT read before anything is built or run
            fmu_dir = getattr(args, "fmu_dir", None)
            if fmu_dir is not None and not fmu_dir.is_dir():  # an existing folder may be read-only: prebuilt
                check_output_folder(fmu_dir, "--fmu-dir")
            live.ask(live_of(args))  # before a command forks its recordings' writer (``recording.live``)
            try:
                code = args.func(args)
            finally:
                live.ask(None)  # for this command only (main may be called again in one process)
        except interrupt.NothingRan as exc:  # here or after a command's own imports
            code, stopped = interrupt.exit_code(), str(exc)
        except interrupt.Interrupted:
            code = interrupt.exit_code()
        except BuildInterrupted:  # the build child was stopped and cleaned up: no run started
            code, stopped = interrupt.exit_code(), "stopped while building FMUs; nothing ran"
        except BrokenPipeError:  # the reader of stdout went away (| head): nothing left to say, no error line
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # so the exit's flush is quiet too
            return exit_codes.PIPE_CLOSED
        except (UsageError, BuildError, OutputError, OSError) as exc:
            if interrupt.requested():
                code = interrupt.exit_code()
            else:  # a request that cannot run as given (2); an output that cannot be written (1)
                print(f"sotc-cosim: error: {exc}", file=sys.stderr)
                return exit_codes.USAGE if isinstance(exc, (UsageError, BuildError)) else exit_codes.FAILED
        if interrupt.requested():
            print(f"sotc-cosim: interrupted ({interrupt.signal_name()}): {stopped}", file=sys.stderr)
            return interrupt.exit_code()
        return code


def console() -> None:
    """The ``sotc-cosim`` script: ``main``, then, after ``run``, out without tearing the interpreter down.
    When ``run`` returns, its outputs are written, closed and renamed, its writer process reaped and its
    FMUs freed: finalizing the interpreter (the loaded FMU binaries, numpy, fmpy) only took time, about
    40 ms of a one-step run's 0.5 s. Every other command exits as usual.

    First, before anything imports numpy: one BLAS thread unless the user chose (``orchestration.threads``)."""
    one_blas_thread()
    argv = sys.argv[1:]
    code = main(argv)
    if argv[:1] != ["run"]:
        sys.exit(code)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except OSError:  # a closed pipe (| head): what was left to print has nowhere to go
        pass
    os._exit(code)


if __name__ == "__main__":
    console()
