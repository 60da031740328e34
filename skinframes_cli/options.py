"""Option parsers shared by several subcommands: every value is checked where it is parsed.

Integers are checked against their documented range, floats must be finite (``nan``, ``inf``
and ``1e400`` are refused) and lists are bounded in length, so no option can ask for unbounded
memory or time. argparse turns an ``ArgumentTypeError`` into one ``skinframes: error:`` line and
exit status 2.
"""

from __future__ import annotations

import argparse
import decimal
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Final

from skinframes.protocols import PROTOCOL_ALIASES, protocol_name
from skinframes.text import escape
from skinframes_cli.streams import STDIO

if TYPE_CHECKING:
    from emulator.model.params import TimingParams

__all__ = [
    "MAX_LIST_VALUES",
    "add_cn_response",
    "bounded_float",
    "bounded_int",
    "file_output",
    "finite_float",
    "in_path",
    "int_list",
    "int_list_in",
    "int_up_to",
    "out_path",
    "positive_float",
    "protocol_arg",
    "timing",
]

MAX_LIST_VALUES: Final = 10_000  # values one start:stop:step or comma list may select
MAX_INT_DIGITS: Final = 20  # longer integers are refused before int() converts them


def _int(text: str, what: str) -> int:
    t = text.strip()
    if len(t) > MAX_INT_DIGITS:
        raise argparse.ArgumentTypeError(f"{escape(text)!r}: {what} too long to be sensible")
    try:
        return int(t)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{escape(text)!r}: expected {what}") from None


def bounded_int(lo: int, hi: int) -> Callable[[str], int]:
    """An argparse ``type``: an integer in ``lo..hi`` (inclusive)."""

    def parse(text: str) -> int:
        value = _int(text, "an integer")
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"{value}: expected an integer in {lo}..{hi}")
        return value

    parse.__name__ = "integer"
    return parse


def bounded_float(lo: float, hi: float) -> Callable[[str], float]:
    """An argparse ``type``: a finite number in ``lo..hi`` (inclusive)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{escape(text)!r}: expected a number") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{escape(text)!r}: expected a finite number")
        if not lo <= value <= hi:
            span = f"in {lo:g}..{hi:g}" if math.isfinite(lo) else f"up to {hi:g}"
            raise argparse.ArgumentTypeError(f"{value:g}: expected a number {span}")
        return value

    parse.__name__ = "number"
    return parse


def int_up_to(hi: int) -> Callable[[str], int]:
    """An argparse ``type``: an integer no larger than ``hi`` (the command checks the lower end
    with its own message)."""

    def parse(text: str) -> int:
        value = _int(text, "an integer")
        if value > hi:
            raise argparse.ArgumentTypeError(f"{value}: expected an integer up to {hi}")
        return value

    parse.__name__ = "integer"
    return parse


def finite_float(hi: float) -> Callable[[str], float]:
    """An argparse ``type``: a finite number no larger than ``hi`` (the command checks the
    lower end with its own message)."""
    return bounded_float(-math.inf, hi)


def positive_float(hi: float) -> Callable[[str], float]:
    """An argparse ``type``: a finite number above 0, up to ``hi`` (a period, a rate)."""
    up_to = finite_float(hi)

    def parse(text: str) -> float:
        value = up_to(text)
        if not value > 0:
            raise argparse.ArgumentTypeError(f"{value:g}: expected a number above 0, up to {hi:g}")
        return value

    parse.__name__ = "number"
    return parse


def out_path(text: str) -> str:
    """An argparse ``type`` for a file or folder to write: not empty."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty file name")
    return text


def in_path(text: str) -> str:
    """An argparse ``type`` for a file to read (``-``: standard input): not empty, as
    :func:`out_path`."""
    return out_path(text)


def file_output(text: str) -> str:
    """An argparse ``type`` for an output a pipe cannot carry (a folder, a picture, a numpy
    file): :func:`out_path`, and not ``-``."""
    if text == STDIO:
        raise argparse.ArgumentTypeError(
            f"{STDIO!r}: this output is written to files only, not to standard output "
            "(./- names a file called -)"
        )
    return out_path(text)


def protocol_arg(
    p: argparse.ArgumentParser, *flags: str, choices: tuple[str, ...], help: str = "", **kw: Any
) -> None:
    """Add a protocol argument (``simulate {epl,ecat}``, ``can convert --to``): ``choices`` and
    their aliases (``ethercat`` for ``ecat``), which argparse turns into the name before it
    checks the choice; ``kw`` goes to ``add_argument`` (``dest``, ``required``)."""
    aliases = [a for a, name in PROTOCOL_ALIASES.items() if name in choices]
    note = ", ".join(f"{a}: alias of {PROTOCOL_ALIASES[a]}" for a in aliases)
    p.add_argument(
        *flags,
        type=protocol_name,
        choices=choices,
        metavar="{" + ",".join((*choices, *aliases)) + "}",
        help="; ".join(t for t in (help, note) if t) or None,
        **kw,
    )


def int_list(text: str, lo: int = 0, hi: int = 1 << 32) -> list[int]:
    """``start:stop:step`` (stop inclusive) or a comma list, e.g. ``130:200:10`` or ``2,32``.

    At most :data:`MAX_LIST_VALUES` values, each in ``lo..hi``.
    """
    syntax = (
        f"{escape(text)!r}: expected start:stop:step (stop inclusive) or a comma list of integers"
    )
    if ":" in text:
        try:
            parts = [_int(p, "an integer") for p in text.split(":")]
        except argparse.ArgumentTypeError:
            raise argparse.ArgumentTypeError(syntax) from None
        if len(parts) not in (2, 3) or (len(parts) == 3 and parts[2] <= 0):
            raise argparse.ArgumentTypeError(syntax)
        selected = range(parts[0], parts[1] + 1, parts[2] if len(parts) == 3 else 1)
        count = len(selected)
    else:
        items = [p for p in text.split(",") if p.strip()]
        count = len(items)
    if count > MAX_LIST_VALUES:
        raise argparse.ArgumentTypeError(
            f"{escape(text)!r} selects {count} values, at most {MAX_LIST_VALUES} are allowed"
        )
    if ":" in text:
        values = list(selected)
    else:
        try:
            values = [_int(p, "an integer") for p in items]
        except argparse.ArgumentTypeError:
            raise argparse.ArgumentTypeError(syntax) from None
    if not values:
        raise argparse.ArgumentTypeError(f"{escape(text)!r} selects no values")
    bad = [v for v in values if not lo <= v <= hi]
    if bad:
        raise argparse.ArgumentTypeError(f"{bad[0]}: each value must be in {lo}..{hi}")
    return values


def add_skin_layout(p: argparse.ArgumentParser, what: str) -> None:
    """``--nodes N --bytes B --layout L``: where a capture's taxels sit (default: inferred)."""
    p.add_argument(
        "--nodes",
        type=bounded_int(1, 1024),
        help=f"EPL CNs / EtherCAT slaves {what} (1..1024; default: inferred)",
    )
    p.add_argument(
        "--bytes",
        type=bounded_int(1, 1490),
        help=f"taxel bytes per node {what} (1..1490; default: inferred; 192 = a patch)",
    )
    p.add_argument(
        "--layout",
        choices=["per-slave", "logical"],
        help=f"EtherCAT process image {what}: one LRD per slave, or one contiguous logical image "
        "(default: inferred)",
    )


def add_can_log(p: argparse.ArgumentParser, help: str) -> None:
    """``LOG`` (a CAN log file, or ``-`` for standard input) and ``--log-format FMT``, the format
    of standard input, which has no suffix to tell it."""
    from skinframes.canbus.log import PCAP_SUFFIXES, PYTHON_CAN_SUFFIXES

    p.add_argument(
        "trace", metavar="LOG", type=in_path, help=f"{help}; - for standard input (--log-format)"
    )
    known = [s.lstrip(".") for s in (*PYTHON_CAN_SUFFIXES, *PCAP_SUFFIXES)]
    p.add_argument(
        "--log-format",
        metavar="FMT",
        help=f"the format of a log read from standard input (LOG -): {', '.join(known)} "
        "(text formats and pcap also FMT.gz)",
    )


def can_log_suffix(args: argparse.Namespace) -> str:
    """The suffix the copy of standard input gets (``LOG -``), from ``--log-format``.

    Raises:
        SkinframesError: ``-`` without ``--log-format``, or ``--log-format`` with a file.
    """
    from skinframes.errors import SkinframesError

    if args.trace == "-":
        if args.log_format is None:
            raise SkinframesError("LOG -: standard input has no suffix; --log-format FMT names it")
        from skinframes.canbus.log import can_log_format

        suffix = "." + str(args.log_format).lstrip(".")
        can_log_format(f"--log-format {suffix}")  # one error line naming the known formats
        return suffix
    if args.log_format is not None:
        raise SkinframesError(
            f"--log-format: for standard input (LOG -); {escape(args.trace)} has its suffix"
        )
    return ""


def frame_ranges(text: str) -> tuple[tuple[int, int | None], ...]:
    """An argparse ``type``: frame numbers (Wireshark's, from 1) as a comma list of ``N``,
    ``A:B`` (inclusive) and ``A:`` (from A on), e.g. ``1:10,15,100:``."""
    ranges: list[tuple[int, int | None]] = []
    parts = text.split(",")
    if len(parts) > MAX_LIST_VALUES:
        raise argparse.ArgumentTypeError(f"more than {MAX_LIST_VALUES} ranges")
    for part in parts:
        lo_text, colon, hi_text = part.partition(":")
        if ":" in hi_text:  # A:B:C (a step, as in --nodes): not a frame range
            raise argparse.ArgumentTypeError(
                f"{escape(part)!r}: expected N, A:B or A: (no step for frames)"
            )
        lo = _int(lo_text, "a frame number") if lo_text.strip() or not colon else 1
        hi = (_int(hi_text, "a frame number") if hi_text.strip() else None) if colon else lo
        if lo < 1 or (hi is not None and hi < lo):
            raise argparse.ArgumentTypeError(
                f"{escape(part)!r}: expected N, A:B or A: with 1 <= A <= B (frames count from 1)"
            )
        ranges.append((lo, hi))
    return tuple(ranges)


frame_ranges.__name__ = "frame list"


def int_list_in(lo: int, hi: int) -> Callable[[str], list[int]]:
    """An argparse ``type``: :func:`int_list` with every value in ``lo..hi``."""

    def parse(text: str) -> list[int]:
        return int_list(text, lo, hi)

    parse.__name__ = "list"
    return parse


CN_RESPONSE_MAX_US: Final = 1_000_000  # emulator.model.params.MAX_CN_RESPONSE_PS, in us


def cn_response_ps(text: str) -> int:
    """An argparse ``type``: a CN response time in us (``90``, ``92.5``), as integer ps; more
    than 0 and at most 1 s, to the ps."""
    t = text.strip()
    if len(t) > MAX_INT_DIGITS:
        raise argparse.ArgumentTypeError(f"{escape(text)!r}: too long to be sensible")
    try:
        us = decimal.Decimal(t)
    except decimal.InvalidOperation:
        raise argparse.ArgumentTypeError(f"{escape(text)!r}: expected a time in us") from None
    if not us.is_finite() or not 0 < us <= CN_RESPONSE_MAX_US:
        raise argparse.ArgumentTypeError(
            f"{escape(text)!r}: a CN response time in us, above 0 and at most {CN_RESPONSE_MAX_US}"
        )
    ps = us * 1_000_000
    if ps != ps.to_integral_value():
        raise argparse.ArgumentTypeError(f"{escape(text)!r}: at most 6 decimals (whole ps)")
    return int(ps)


def add_cn_response(p: argparse.ArgumentParser) -> None:
    """``--cn-response-us US``: a measured EPL CN response time in place of the preset's D_CN
    (:func:`emulator.model.params.with_cn_response`); read with :func:`timing`."""
    p.add_argument(
        "--cn-response-us",
        dest="cn_response_ps",
        type=cn_response_ps,
        metavar="US",
        default=None,
        help="EPL: each CN answers its PReq this many us after it (D_CN) instead of the "
        "preset's 1 us of a hardware CN; a software CN is far slower (the openPOWERLINK CN on "
        "Linux: about 100 us median, up to 600 us on veth)",
    )


def timing(args: argparse.Namespace) -> TimingParams:
    """The timing constants the options choose: ``--preset``, and ``--cn-response-us`` where
    the command has it."""
    from emulator.model.params import preset, with_cn_response

    return with_cn_response(preset(args.preset), getattr(args, "cn_response_ps", None))
