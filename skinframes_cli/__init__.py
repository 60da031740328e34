"""The ``skinframes`` command: one module per subcommand, listed explicitly in COMMANDS.

The top layer: it imports ``skinframes`` (bytes) and ``emulator`` (time); neither imports it
(``tests/test_layering.py``). A command module parses arguments and formats output; what to
compute, and every limit and name it checks against, comes from the libraries.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import signal
import sys
from collections.abc import Iterator, Mapping, Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any, Final

from skinframes import __version__
from skinframes.errors import SkinframesError
from skinframes.text import escape
from skinframes_cli import signals
from skinframes_cli.signals import Terminated

__all__ = ["Terminated", "main"]

EXIT_SIGINT: Final = 128 + signal.SIGINT  # 130, as a shell reports a process ended by SIGINT
EXIT_SIGTERM: Final = 128 + signal.SIGTERM  # 143

# The command modules, in --help order; each registers one subcommand (``add_parser``). A run
# imports only the module of its command (start-up time: ``check`` needs no numpy, emulator or
# matplotlib); ``--help``, an unknown command and :func:`build_parser` import them all.
COMMAND_MODULES: Final = (
    "demo",
    "tables",
    "simulate",
    "plan",
    "plot",
    "decode",
    "check",
    "analyze",
    "watch",
    "can",
    "compare",
    "serve",
    "epl_config",
    "wireshark_plugin",
    "vectors",
    "sii",
)


GLOBAL_FLAGS: Final = ("--debug", "-q", "--quiet")  # options before the command, taking no value


def _command_module(name: str) -> ModuleType:
    return importlib.import_module(f"{__name__}.{name}")


if not TYPE_CHECKING:

    def __getattr__(name: str) -> Any:
        """``COMMANDS``, the command modules themselves, imported when first asked for."""
        if name == "COMMANDS":
            return tuple(_command_module(m) for m in COMMAND_MODULES)
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors as one ``skinframes: error:`` line and exit 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        print(f"skinframes: error: {escape(message)} (see '{self.prog} --help')", file=sys.stderr)
        raise SystemExit(2)


@contextlib.contextmanager
def _information(quiet: bool) -> Iterator[None]:
    """``-q``: what a command prints on stderr while it runs is information (errors are raised
    and printed by :func:`main` afterwards, as one ``skinframes: error:`` line): drop it."""
    if not quiet:
        yield
        return
    import os

    with open(os.devnull, "w") as devnull, contextlib.redirect_stderr(devnull):
        yield


def _quiet_stdout() -> None:
    """The reader of stdout left (``| head``): send the rest to /dev/null, print nothing more."""
    import os

    with contextlib.suppress(OSError, ValueError):
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def build_parser(modules: Sequence[str] = COMMAND_MODULES) -> argparse.ArgumentParser:
    """The full argument parser (exposed for documentation and tests); ``modules``: only the
    subcommands of these :data:`COMMAND_MODULES`."""
    parser = _Parser(
        prog="skinframes",
        description="Build, check and time the EPL, EtherCAT and CAN frames of a robot skin.",
    )
    _global_flags(parser, False)
    parser.add_argument(
        "--version",
        action="version",
        version=f"skinframes {__version__}",
        help="print 'skinframes VERSION' on stdout and exit 0",
    )
    sub = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=_Parser
    )
    for name in modules:
        _command_module(name).add_parser(sub)
    _after_commands(sub.choices)
    return parser


def _after_commands(commands: Mapping[str, argparse.ArgumentParser]) -> None:
    """:data:`GLOBAL_FLAGS` after the command too, and after a command's own (``can
    decode``); aliases share their parser."""
    for command in {id(p): p for p in commands.values()}.values():
        _global_flags(command, argparse.SUPPRESS)
        for action in command._actions:
            if isinstance(action, argparse._SubParsersAction):
                _after_commands(action.choices)


def _global_flags(parser: argparse.ArgumentParser, default: object) -> None:
    """:data:`GLOBAL_FLAGS` on ``parser``: before the command with ``default`` False, and
    after it with SUPPRESS, so that a flag given there is taken and one not given leaves the
    first's value."""
    parser.add_argument(
        "--debug", action="store_true", default=default, help="show tracebacks on errors"
    )
    parser.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        default=default,
        help="print no information on stderr (counts, summaries, progress); errors still print",
    )


def _modules_for(argv: Sequence[str]) -> Sequence[str]:
    """The command module ``argv`` runs, alone; all of them where argv names none plainly
    (``--help``, an abbreviated option, a misspelt command: argparse then says what it always
    says)."""
    for arg in argv:
        if arg in GLOBAL_FLAGS:
            continue
        name = arg.replace("-", "_")  # the command wireshark-plugin lives in wireshark_plugin
        if name in COMMAND_MODULES and arg == name.replace("_", "-"):
            return (name,)
        break
    return COMMAND_MODULES


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 ok, 1 problems found, 2 bad input)."""
    if argv is None:
        argv = sys.argv[1:]
    debug = False  # (--debug, once the arguments are read)
    try:
        # the signals are the command's from here: importing a command's module (numpy,
        # matplotlib) takes up to half a second, where a Ctrl-C gave Python's traceback
        with signals.handled():
            try:
                args = build_parser(_modules_for(argv)).parse_args(argv)
            except SystemExit as exc:  # usage errors (exit 2) and --help (exit 0), as a code
                return exc.code if isinstance(exc.code, int) else 2
            debug = args.debug
            with _information(args.quiet):
                code: int = args.run(args)
                signals.raise_if_signalled()  # one that something swallowed: not a success
        return code
    except SkinframesError as exc:
        if debug:
            raise
        print(f"skinframes: error: {escape(exc)}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `skinframes decode x | head`: the reader left, stop quietly
        _quiet_stdout()
        return 0
    except OSError as exc:
        if debug:
            raise
        text = f"{exc.strerror or exc}: {exc.filename or ''}".rstrip(": ")
        print(f"skinframes: error: {escape(text)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("skinframes: interrupted (SIGINT); no file was left half-written", file=sys.stderr)
        return EXIT_SIGINT
    except Terminated:
        print("skinframes: terminated (SIGTERM); no file was left half-written", file=sys.stderr)
        return EXIT_SIGTERM
