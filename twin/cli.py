"""The `twin` command: one entry point with subcommands (STYLE rule 12).

Each area registers its own subcommands: twin.commands (run, sweep, paper, bench),
twin.log_commands (view, replay) and gap.commands (gap diagnose, gap bench). A user error
(bad file, field or value) is printed as one line and exits with status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from pneumatics import ParameterError
from twin.errors import UserError

# modules that define `register(subparsers)`; missing ones are skipped so the CLI still starts
COMMAND_MODULES = ("twin.commands", "twin.log_commands", "gap.commands", "scenarios.commands")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="twin", description="Digital twin of the sensorless pneumatic manipulator.")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as e:
            if e.name != name:
                raise
            continue
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (UserError, ParameterError) as e:
        print(f"twin: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("twin: interrupted; the logs written so far are kept", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
