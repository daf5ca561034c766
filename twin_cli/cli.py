"""The `twin` command: one entry point with subcommands (STYLE rule 12).

Each area's subcommands are a module of twin_cli: run_commands (run, sweep, paper, bench),
log_commands (view, replay), plot_command (plot), study_commands (study) and gap_commands (gap
diagnose, gap bench). A user error (bad file, field or value, on the command line too) is printed
as one line and exits with status 2, never a traceback. Ctrl-C (SIGINT) and SIGTERM (what
`timeout`, systemd and docker send) both stop a run the same way: it finishes its logs, says so,
and exits 130 or 143.

A command imports the libraries it calls when it runs, not at its module's top: imported there
they take `twin --help` from 0.15 s to 2.2 s (`python -X importtime -c "import twin_cli.cli"`,
cumulative import time). `twin --version` and `--help` load neither numba nor numpy
(tests/test_reliability.py): the package pneumatics loads its compiled laws on first use.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from importlib import metadata

from twin_cli import gap_commands, log_commands, plot_command, run_commands, study_commands
from twin_plumbing.errors import ParameterError, Terminated, UserError
from twin_plumbing.signals import stop_behind, stop_on_sigterm

# each defines `register(subparsers)`; the order is that of `twin --help`
COMMAND_MODULES = (run_commands, log_commands, plot_command, gap_commands, study_commands)


class _CurrentStderr(logging.Handler):
    """Log records as "twin: message" lines on sys.stderr as it is when the record comes (not as it
    was when the handler was made: tests and callers swap sys.stderr)."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            sys.stderr.write(f"twin: {record.getMessage()}\n")
        except Exception:  # noqa: BLE001 - logging must never end a run
            self.handleError(record)


def configure_logging(verbose: bool) -> None:
    """The libraries log (stdlib logging); the command line shows their warnings, and with
    --verbose what they do (INFO), one line each on stderr."""
    root = logging.getLogger()
    if not any(isinstance(h, _CurrentStderr) for h in root.handlers):
        root.addHandler(_CurrentStderr())
    root.setLevel(logging.INFO if verbose else logging.WARNING)


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a bad command line is one line on stderr (what is wrong and where to look),
    exit status 2, like every other user error of the twin."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def version() -> str:
    try:
        return metadata.version("pneumatic-arm-twin")
    except metadata.PackageNotFoundError:  # run from a source tree that was never installed
        return "unknown (not installed)"


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog="twin", description="Digital twin of the sensorless pneumatic manipulator.")
    parser.add_argument(
        "--version", action="version", version=f"%(prog)s {version()}", help="print the version and exit"
    )
    parser.add_argument(
        "-v", "--verbose", action="store_true", help="say what the libraries do (their log, INFO and above) on stderr"
    )
    sub = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", help="what to do (each has its own --help)"
    )
    for module in COMMAND_MODULES:
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    configure_logging(args.verbose)
    try:
        with stop_on_sigterm():
            return int(args.func(args) or 0)
    except (UserError, ParameterError) as e:
        print(f"twin: error: {e}", file=sys.stderr)
        return 2
    except BaseException as e:  # noqa: BLE001 - re-raised unless it is a stop
        stop = stop_behind(e)  # also a stop that compiled code turned into a SystemError
        if stop is None:
            raise
        # what a stopped command kept, where it keeps something it does not say itself (its logs)
        kept = f"; {args.kept_on_stop}" if getattr(args, "kept_on_stop", "") else ""
        if isinstance(stop, Terminated):
            print(f"twin: terminated (SIGTERM){kept}", file=sys.stderr)
            return 128 + signal.SIGTERM
        print(f"twin: interrupted{kept}", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
