"""The ``skinframes`` command: one module per subcommand, listed explicitly in COMMANDS.

The top layer: it imports ``skinframes`` (bytes) and ``emulator`` (time); neither imports it
(``tests/test_layering.py``). A command module parses arguments and formats output; what to
compute, and every limit and name it checks against, comes from the libraries.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Final

from skinframes.errors import SkinframesError
from skinframes_cli import (
    analyze,
    can,
    check,
    compare,
    decode,
    demo,
    plan,
    plot,
    serve,
    simulate,
    tables,
    vectors,
    wireshark_plugin,
)

__all__ = ["main"]

COMMANDS: Final = (
    demo,
    tables,
    simulate,
    plan,
    plot,
    decode,
    check,
    analyze,
    can,
    compare,
    serve,
    wireshark_plugin,
    vectors,
)


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors as one ``skinframes: error:`` line and exit 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        print(f"skinframes: error: {message} (see '{self.prog} --help')", file=sys.stderr)
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser (exposed for documentation and tests)."""
    parser = _Parser(
        prog="skinframes",
        description="Build, check and time the EPL, EtherCAT and CAN frames of a robot skin.",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=_Parser
    )
    for command in COMMANDS:
        command.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 ok, 1 problems found, 2 bad input)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # usage errors (exit 2) and --help (exit 0), as a return code
        return exc.code if isinstance(exc.code, int) else 2
    try:
        code: int = args.run(args)
        return code
    except SkinframesError as exc:
        if args.debug:
            raise
        print(f"skinframes: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `skinframes decode x | head`: the reader left, stop quietly
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:
        if args.debug:
            raise
        print(
            f"skinframes: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "),
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        return 130
