"""Line parsers for Vector ASC and candump ``.log``: one CAN frame or one reason per line.

They read what python-can 4.6's ``ASCReader`` and ``CanutilsLogReader`` read, frame for frame
(the same :class:`~skinframes.canbus.wire.CanFrame` that :func:`~skinframes.canbus.log.from_message`
makes of python-can's message; tested on the project's CAN logs and on random frames with
hypothesis), with two differences that lose nothing:

- every line is accounted for: a line that is not a frame comes back as a :class:`LineSkip`
  with its reason (python-can passes over ASC lines it does not know in silence, and its candump
  reader stops at the first line it cannot split);
- python-can's ASC reader drops the first line after a header that has no ``internal events
  logged`` line; it is read here.

Formats: Vector "ASCII Logging File" (CANoe/CANalyzer ``.asc``: a header of ``date``, ``base``,
``internal events logged`` lines, then ``<time s> <channel> <id>[x] <Rx|Tx> d <dlc> <bytes>``
lines, ``CANFD`` lines and events); candump ``-l``/``-L`` (``(<time s>) <interface>
<id>#<hex>``, ``<id>##<flags><hex>`` for CAN FD, ``<id>#R<dlc>`` for remote frames; can-utils
``lib.c``). The parsers are a few times faster than python-can's, which makes
``skinframes can decode`` faster than ``can.LogReader`` iteration (benchmarks/bench_can_log.py).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import IO, Final

from skinframes.canbus.wire import MAX_DATA_BYTES, MAX_DLC, CanFrame

__all__ = [
    "DataTuple",
    "LineSkip",
    "LineTally",
    "parse_asc",
    "parse_asc_file",
    "parse_candump",
    "parse_candump_file",
]

DataTuple = tuple[int, int, bytes, "int | str | None"]
"""``(time_ns, arbitration_id, data, channel)``: a classic 11-bit data frame of at most 8 bytes
whose DLC is ``len(data)`` (the common case, left as a tuple: building a :class:`CanFrame` costs
more than parsing the line)."""

NS_PER_S: Final = 1_000_000_000
# python-can's dlc2len (ISO 11898-1:2015 Table 5: CAN FD DLC 9..15 -> 12..64 bytes)
_DLC_TO_LEN: Final = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)
# python-can's ASC_MESSAGE_REGEX and ASC_TRIGGER_REGEX (can/io/asc.py)
_ASC_MESSAGE: Final = re.compile(
    r"\d+\.\d+\s+(\d+\s+(\w+\s+(Tx|Rx)|ErrorFrame)|CANFD)", re.ASCII | re.IGNORECASE
)
_ASC_MESSAGE_LSTRIP: Final = re.compile(r"\s*" + _ASC_MESSAGE.pattern, re.ASCII | re.IGNORECASE)
_ASC_TRIGGER: Final = re.compile(r"begin\s+triggerblock\s+\w+\s+(.+)", re.IGNORECASE)
_ASC_HEADER: Final = re.compile(
    r"(date\s+\w+\s+.+|base\s+(hex|dec)\b.*|(no)?\s*internal\s+events\s+logged|"
    r"end\s+triggerblock)",
    re.IGNORECASE,
)
_ASC_TIMED: Final = re.compile(r"\d+\.\d+\s", re.ASCII)
_ASC_BASE: Final = re.compile(r"base\s+(hex|dec)", re.IGNORECASE)
_DIRECTIONS: Final = frozenset(("Rx", "Tx", "rx", "tx", "RX", "TX", "rX", "tX"))
CAN_ERR_FLAG: Final = 0x20000000  # linux/can.h
CAN_ERR_BUSERROR: Final = 0x00000080  # linux/can/error.h: bus error (may flood!)
CAN_EFF_MASK: Final = 0x1FFFFFFF

# skip reasons (grouped by these strings when counted)
EMPTY: Final = "empty line"
ASC_HEADER: Final = "ASC header line (date, base, internal events, triggerblock)"
ASC_COMMENT: Final = "ASC comment line"
ASC_EVENT: Final = "ASC event line, not a CAN frame (start of measurement, statistics, ...)"
ASC_NOT_A_LINE: Final = "not an ASC line"
CANDUMP_NOT_A_LINE: Final = "not a candump line"


@dataclass(frozen=True, slots=True)
class LineSkip:
    """A line that is not a CAN frame: ``reason`` is one of a few fixed texts (count by it),
    ``detail`` says what was wrong with this line, ``damage`` is False for the lines a log
    carries on purpose (header, comments, events, empty lines)."""

    reason: str
    detail: str = ""
    damage: bool = False


_EMPTY: Final = LineSkip(EMPTY)


def _time_ns(text: str) -> int:
    return round(float(text) * NS_PER_S)  # as python-can's float seconds -> from_message


def _classic(
    ident: int,
    extended: bool,
    data: bytes,
    dlc: int,
    time_ns: int,
    channel: int | str | None,
) -> CanFrame | DataTuple:
    """The frame :func:`~skinframes.canbus.log.from_message` makes of a classic message."""
    if (
        not extended
        and len(data) <= MAX_DATA_BYTES
        and (dlc <= MAX_DATA_BYTES or len(data) < MAX_DATA_BYTES)
    ):
        return (time_ns, ident, data, channel)
    if len(data) > MAX_DATA_BYTES:
        return CanFrame(ident, data, time_ns=time_ns, extended=extended, fd=True, channel=channel)
    keep = dlc if len(data) == MAX_DATA_BYTES and MAX_DATA_BYTES < dlc <= MAX_DLC else None
    return CanFrame(ident, data, time_ns=time_ns, extended=extended, dlc=keep, channel=channel)


def _remote(
    ident: int, extended: bool, dlc: int, time_ns: int, channel: int | str | None
) -> CanFrame:
    """A remote frame as from_message makes it (a DLC outside 0..15 is not kept)."""
    return CanFrame(
        ident,
        b"",
        time_ns=time_ns,
        extended=extended,
        remote=True,
        dlc=dlc if 0 <= dlc <= MAX_DLC else None,
        channel=channel,
    )


# --- ASC -------------------------------------------------------------------------------------------
def parse_asc(lines: Iterable[str]) -> Iterator[CanFrame | DataTuple | LineSkip]:
    """One frame (:class:`CanFrame` or :data:`DataTuple`) or :class:`LineSkip` per line of a
    Vector ASC log.

    Timestamps are relative to the measurement start, as python-can's default
    (``relative_timestamp=True``) gives them.
    """
    state = _AscState()
    return (_asc_line(line, state) for line in lines)


class LineTally:
    """What :func:`parse_asc_file` and :func:`parse_candump_file` read besides the frames they
    yield: ``lines`` read so far (complete when the parser is exhausted), and ``on_skip(index,
    skip)`` called for every line that is not a frame."""

    __slots__ = ("lines", "on_skip")

    def __init__(self, on_skip: Callable[[int, LineSkip], object]) -> None:
        self.lines = 0
        self.on_skip = on_skip

    def take(self, lines: Iterable[str], state: _AscState) -> Iterator[CanFrame | DataTuple]:
        """The ASC lines one by one, from line number ``self.lines`` on."""
        for line in lines:
            item = _asc_line(line, state)
            if isinstance(item, LineSkip):
                self.on_skip(self.lines, item)
            else:
                yield item
            self.lines += 1


BLOCK_CHARS: Final = 1 << 18  # characters of lines parsed at once (a file)
STREAM_BLOCK_CHARS: Final = 1 << 12  # the same for a stream: frames out soon after lines in


def parse_asc_file(
    text: IO[str], tally: LineTally, block_chars: int = BLOCK_CHARS
) -> Iterator[list[CanFrame | DataTuple]]:
    """The frames of :func:`parse_asc` of a text file, a list per block of about
    ``block_chars`` characters (a stream: fewer, so that frames come out as lines come in); the
    other lines go to ``tally``.

    The plain data frames of a block (``<t> <ch> <id> Rx|Tx d <dlc 0..8> <bytes>``,
    hexadecimal, one space before each byte) are found with one regular expression, the lines
    between them are read one by one.
    """
    state = _AscState()
    for block in _line_blocks(text, block_chars):
        if block.endswith("\n"):
            first = tally.lines
            yield _asc_block(block, state, tally)
            tally.lines = first + block.count("\n")
        else:  # the last line, without its newline
            yield list(tally.take(block.split("\n"), state))


def _line_blocks(text: IO[str], block_chars: int) -> Iterator[str]:
    """Whole lines of ``text`` joined into blocks of about ``block_chars`` characters. When
    reading fails (a truncated gzip stream, bytes that are not UTF-8), the lines read before
    come out first, then the error."""
    lines: list[str] = []
    size = 0
    try:
        for line in text:
            lines.append(line)
            size += len(line)
            if size >= block_chars:
                yield "".join(lines)
                lines, size = [], 0
    except GeneratorExit:  # the consumer stopped (a reader that left): nothing more to give
        raise
    except BaseException:
        if lines:
            yield "".join(lines)
        raise
    if lines:
        yield "".join(lines)


def _asc_block(block: str, state: _AscState, tally: LineTally) -> list[CanFrame | DataTuple]:
    """The frames of a block of whole lines: plain data frames found by :data:`_ASC_PLAIN`, the
    lines between them (headers, events, anything else) read one by one."""
    out: list[CanFrame | DataTuple] = []
    append = out.append
    first = tally.lines
    pos = 0
    fromhex = bytes.fromhex
    for m in _ASC_PLAIN.finditer(block) if state.base == 16 else ():
        start = m.start()
        if start != pos:
            tally.lines = first + block.count("\n", 0, pos)
            out.extend(tally.take(block[pos : start - 1].split("\n"), state))
            if state.base != 16:  # a "base dec" line: the rest is not hexadecimal
                pos = start
                break
        pos = m.end()
        stamp, channel, ident, dlc_text, rest = m.groups()
        dlc = int(dlc_text)
        end = 3 * dlc  # " XX" per byte: python-can's first dlc tokens, each two hex digits
        if rest[0:end:3] == _SPACES[dlc] and rest[end : end + 1] in _AFTER_DATA:
            try:
                append(
                    (
                        round(float(stamp) * NS_PER_S),
                        int(ident, 16),
                        fromhex(rest[:end]),
                        int(channel) - 1,
                    )
                )
                continue
            except ValueError:
                pass
        tally.lines = first + block.count("\n", 0, start)  # any other layout: the general path
        out.extend(tally.take([m.group()[:-1]], state))
    if pos != len(block):
        tally.lines = first + block.count("\n", 0, pos)
        out.extend(tally.take(block[pos:-1].split("\n"), state))
    return out


# a plain data frame line up to its DLC, as CANoe and python-can write it; every field within
# what _ASC_MESSAGE and python-can's _process_classic_can_frame accept (a narrower set)
_ASC_PLAIN: Final = re.compile(
    r"^[ \t]*([0-9]+\.[0-9]+)[ \t]+([0-9]+)[ \t]+([0-9A-Fa-f]+)[ \t]+(?:Rx|Tx)[ \t]+d[ \t]+([0-8])"
    r"([^\n]*)\n",
    re.ASCII | re.MULTILINE,
)
_SPACES: Final = tuple(" " * n for n in range(MAX_DATA_BYTES + 1))
_AFTER_DATA: Final = ("", " ", "\t")


class _AscState:
    """What an ASC header sets for the lines after it: the number base of ids and bytes."""

    __slots__ = ("base",)

    def __init__(self) -> None:
        self.base = 16


def _asc_line(raw: str, state: _AscState) -> CanFrame | DataTuple | LineSkip:
    """One line of an ASC log, read as python-can's ASCReader reads it."""
    base = state.base
    parts = raw.split()
    if (
        len(parts) >= 6
        and parts[4] == "d"
        and parts[3] in _DIRECTIONS
        and _ASC_MESSAGE_LSTRIP.match(raw)
    ):
        try:
            return _asc_data_frame(parts, base)
        except (ValueError, IndexError) as exc:
            return LineSkip(ASC_NOT_A_LINE, f"bad CAN frame: {exc}", True)
    line = raw.strip()
    if not line:
        return _EMPTY
    if line.startswith("//"):
        return LineSkip(ASC_COMMENT)
    if _ASC_TRIGGER.match(line) or _ASC_HEADER.match(line):
        if m := _ASC_BASE.match(line):
            state.base = 16 if m.group(1).lower() == "hex" else 10
        return LineSkip(ASC_HEADER)
    if _ASC_MESSAGE.match(line):
        try:
            return _asc_slow(line, base)
        except (ValueError, IndexError) as exc:
            return LineSkip(ASC_NOT_A_LINE, f"bad CAN frame: {exc}", True)
    if _ASC_TIMED.match(line):
        return LineSkip(ASC_EVENT)
    return LineSkip(ASC_NOT_A_LINE, "neither header, comment, event nor frame", True)


def _asc_id(text: str, base: int) -> tuple[int, bool]:
    if text[-1:].lower() == "x":
        return int(text[:-1], base), True
    return int(text, base), False


def _asc_bytes(tokens: list[str], base: int) -> bytes:
    if base == 16:
        try:
            data = bytes.fromhex(" ".join(tokens))
        except ValueError:
            pass
        else:
            if len(data) == len(tokens):  # every token two hex digits
                return data
    return bytes([int(t, base) for t in tokens])  # ValueError for > 255, as bytearray.append


def _asc_data_frame(parts: list[str], base: int) -> CanFrame | DataTuple:
    """``<t> <ch> <id> <dir> d <dlc> <bytes...>`` (python-can's _process_classic_can_frame)."""
    ident, extended = _asc_id(parts[2], base)
    dlc = _DLC_TO_LEN[int(parts[5], base)]
    data = _asc_bytes(parts[6 : 6 + min(MAX_DATA_BYTES, dlc)], base)
    return _classic(ident, extended, data, dlc, _time_ns(parts[0]), int(parts[1]) - 1)


def _asc_slow(line: str, base: int) -> CanFrame | DataTuple | LineSkip:
    """Any line python-can's message regex accepts, read the way ASCReader reads it."""
    stamp, channel, rest = line.split(None, 2)
    time_ns = _time_ns(stamp)
    if channel == "CANFD":
        return _asc_fd(rest, base, time_ns)
    if not channel.isdigit():
        return LineSkip(ASC_EVENT)
    ch = int(channel) - 1
    if rest.strip()[0:10].lower() == "errorframe":
        return CanFrame(0, b"", time_ns=time_ns, error=True, channel=ch)
    id_text, _direction, rest = rest.split(None, 2)
    ident, extended = _asc_id(id_text, base)
    if rest[0].lower() == "r":
        tokens = rest.split()
        dlc = int(tokens[1], base) if len(tokens) > 1 and tokens[1].isdigit() else 0
        return _remote(ident, extended, dlc, time_ns, ch)
    try:
        _, dlc_text, data_text = rest.split(None, 2)
    except ValueError:
        _, dlc_text = rest.split(None, 1)
        data_text = ""
    dlc = _DLC_TO_LEN[int(dlc_text, base)]
    data = _asc_bytes(data_text.split()[: min(MAX_DATA_BYTES, dlc)], base)
    return _classic(ident, extended, data, dlc, time_ns, ch)


def _asc_fd(rest: str, base: int, time_ns: int) -> CanFrame:
    """A ``CANFD`` line (python-can's _process_fd_can_frame)."""
    channel, _direction, rest = rest.split(None, 2)
    ch = int(channel) - 1
    if rest.strip()[:10].lower() == "errorframe":
        return CanFrame(0, b"", time_ns=time_ns, error=True, channel=ch)
    id_text, name_or_brs, rest = rest.split(None, 2)
    if name_or_brs.isdigit():
        _esi, dlc_text, length_text, data_text = rest.split(None, 3)
    else:
        _brs, _esi, dlc_text, length_text, data_text = rest.split(None, 4)
    ident, extended = _asc_id(id_text, base)
    dlc = int(dlc_text, base)
    length = int(length_text)
    data = _asc_bytes(data_text.split()[:length], base)
    if length == 0:
        return _remote(ident, extended, dlc, time_ns, ch)
    return CanFrame(ident, data, time_ns=time_ns, extended=extended, fd=True, channel=ch)


# --- candump ---------------------------------------------------------------------------------------
def parse_candump(lines: Iterable[str]) -> Iterator[CanFrame | DataTuple | LineSkip]:
    """One frame (:class:`CanFrame` or :data:`DataTuple`) or :class:`LineSkip` per line of a
    candump ``-l``/``-L`` log."""
    for raw in lines:
        line = raw.strip()
        if not line:
            yield _EMPTY
            continue
        try:
            yield _candump_line(line)
        except (ValueError, IndexError) as exc:
            yield LineSkip(CANDUMP_NOT_A_LINE, str(exc), True)


def parse_candump_file(
    text: IO[str], tally: LineTally, block_chars: int = BLOCK_CHARS
) -> Iterator[list[CanFrame | DataTuple]]:
    """The frames of :func:`parse_candump` of a text file, a list per block of about
    ``block_chars`` characters; the other lines go to ``tally``."""
    for block in _line_blocks(text, block_chars):
        out: list[CanFrame | DataTuple] = []
        lines = block.split("\n")
        if block.endswith("\n"):
            lines.pop()  # nothing after the last newline
        for raw in lines:
            line = raw.strip()
            if not line:
                tally.on_skip(tally.lines, _EMPTY)
            else:
                try:
                    out.append(_candump_line(line))
                except (ValueError, IndexError) as exc:
                    tally.on_skip(tally.lines, LineSkip(CANDUMP_NOT_A_LINE, str(exc), True))
            tally.lines += 1
        yield out


def _candump_line(line: str) -> CanFrame | DataTuple:
    """python-can's CanutilsLogReader on one stripped, non-empty line."""
    parts = line.split()
    if line[-2:].lower() in (" r", " t"):
        if len(parts) != 4:
            raise ValueError(f"{len(parts)} fields, expected 4")
    elif len(parts) != 3:
        raise ValueError(f"{len(parts)} fields, expected 3 (time, interface, frame)")
    stamp, channel_text, frame = parts[0], parts[1], parts[2]
    time_ns = _time_ns(stamp[1:-1])
    id_text, sep, data_text = frame.partition("#")
    if not sep:
        raise ValueError("no '#' between identifier and data")
    channel: int | str = int(channel_text) if channel_text.isdigit() else channel_text
    extended = len(id_text) > 3
    can_id = int(id_text, 16)
    if can_id & CAN_ERR_FLAG and can_id & CAN_ERR_BUSERROR:
        _candump_data(data_text)  # python-can parses (and may reject) the data first
        return CanFrame(0, b"", time_ns=time_ns, error=True)
    ident = can_id & CAN_EFF_MASK
    fd, remote, dlc, data = _candump_data(data_text)
    if remote:
        return _remote(ident, extended, dlc, time_ns, channel)
    if fd:
        return CanFrame(ident, data, time_ns=time_ns, extended=extended, fd=True, channel=channel)
    return _classic(ident, extended, data, len(data), time_ns, channel)


def _candump_data(text: str) -> tuple[bool, bool, int, bytes]:
    fd = False
    if text and text[0] == "#":
        fd = True
        int(text[1])  # the flags nibble (BRS, ESI): python-can checks it is a digit
        text = text[2:]
    if text and text[0].lower() == "r":
        return fd, True, int(text[1:]) if len(text) > 1 else 0, b""
    if len(text) % 2 == 0:
        try:
            return fd, False, len(text) // 2, bytes.fromhex(text)
        except ValueError:
            pass
    return (
        fd,
        False,
        len(text) // 2,
        bytes([int(text[i : i + 2], 16) for i in range(0, len(text), 2)]),
    )
