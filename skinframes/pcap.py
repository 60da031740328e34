"""Capture files: a reader for pcap, pcapng and gzip; the writers (re-exported here) live in
:mod:`skinframes.capture_writer`.

Formats: classic pcap (tcpdump.org, "draft-ietf-opsawg-pcap"): magic 0xA1B2C3D4 (microseconds) or
0xA1B23C4D (nanoseconds), in either byte order; pcapng ("draft-ietf-opsawg-pcapng"): sections,
several interfaces, ``if_tsresol`` (option 9, 10^-n or 2^-n s) and ``if_tsoffset`` (option 14,
seconds added to every stamp), as Wireshark's wiretap/pcapng.c applies them, and ``if_speed``
(option 8, u64 bits per second; section 4.2), which each record carries as ``if_speed_bps``. Either may be gzip
compressed, several members included (Wireshark reads such files transparently).

Reading streams: records are read one by one from the file (or a pipe), so memory does not grow
with the capture; at most one record (<= 256 KiB, Wireshark's largest) or one pcapng block is
held. Iterating a :class:`Capture` reads the file; ``skipped``, ``findings``, ``total`` and
``len()`` are known after one whole pass (asking for them first makes that pass, holding nothing);
``records`` holds every record in memory, for small files and tests.

Reading accounts for every record: ``len(capture.records) + len(capture.skipped) == capture.total``.
A damaged tail is reported as one skipped entry after the good records before it. What is wrong
but readable (a record longer than the snap length, a pcapng option running past its block,
bytes after the last gzip member) becomes a finding in ``capture.findings``, not a lost record.

Numbering: ``Record.index`` counts records from 0, skipped ones included; ``Record.frame`` is
``index + 1``, Wireshark's ``frame.number`` for the same record.
"""

from __future__ import annotations

import io
import itertools
import logging
import os
import stat
import struct
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Final, Protocol

from skinframes.capture_writer import (
    CAPTURE_SNAPLEN,
    EPB_CRC_ERROR,
    EPB_INBOUND,
    EPB_OUTBOUND,
    LINKTYPE_CAN_SOCKETCAN,
    LINKTYPE_ETHERNET,
    MAGIC_NS,
    MAGIC_US,
    NS_PER_S,
    PCAP_HEADER_BYTES,
    SNAPLEN,
    CaptureWriter,
    MarkedRecord,
    PcapWriter,
    pcap_bytes,
    pcap_header,
    pcapng_bytes,
    record_header,
    write_pcap,
)
from skinframes.errors import PcapFormatError
from skinframes.findings import Finding, FrameFinding, warning

__all__ = [
    "CAPTURE_SNAPLEN",
    "EPB_CRC_ERROR",
    "EPB_INBOUND",
    "EPB_OUTBOUND",
    "LINKTYPE_CAN_SOCKETCAN",
    "LINKTYPE_ETHERNET",
    "NS_PER_S",
    "Capture",
    "CaptureWriter",
    "FirstRecords",
    "MarkedRecord",
    "PcapWriter",
    "Record",
    "RecordSource",
    "Skipped",
    "iter_capture",
    "parse_capture",
    "pcap_bytes",
    "pcap_header",
    "pcapng_bytes",
    "read_capture",
    "record_header",
    "write_pcap",
]

logger = logging.getLogger(__name__)

PCAPNG_MAGIC: Final = b"\x0a\x0d\x0d\x0a"
GZIP_MAGIC: Final = b"\x1f\x8b"
MAX_RECORD_BYTES: Final = SNAPLEN  # 262144: Wireshark's WTAP_MAX_PACKET_SIZE_STANDARD
# Wireshark's wiretap/pcapng.c MAX_BLOCK_SIZE: the smallest EPB + the largest packet + 128 KiB of
# options; a longer block is refused there, and here, so one block in memory stays small
MAX_BLOCK_BYTES: Final = 32 + MAX_RECORD_BYTES + 131072
GZIP_MAX_RATIO: Final = 1000  # deflate cannot exceed ~1032:1; only runs of one byte come close
# judged once this much has been decompressed: 1 MiB, so that a bomb of zero-length records is
# refused after about 65,000 of them (`check` of a 4 MB bomb: 1.1 s; judged after 64 MiB it had
# taken 51 s); the first MiB of real captures expands 2-18:1 (pcaps/, ../shared/captures, and
# 3,000 `simulate` cycles of either protocol, compressed at level 9)
GZIP_RATIO_AFTER_BYTES: Final = 1 << 20
_CHUNK_BYTES: Final = 1 << 16

# pcapng block types and options (draft-ietf-opsawg-pcapng sections 4 and 4.2)
_SHB: Final = 0x0A0D0D0A
_IDB: Final = 1
_PB: Final = 2  # obsolete Packet Block
_SPB: Final = 3
_EPB: Final = 6
_BYTE_ORDER_MAGIC: Final = 0x1A2B3C4D
_OPT_ENDOFOPT: Final = 0
_OPT_COMMENT: Final = 1
_IF_SPEED: Final = 8
_IF_TSRESOL: Final = 9
_IF_TSOFFSET: Final = 14
_DEFAULT_UNITS_PER_S: Final = 1_000_000  # no if_tsresol: microseconds


@dataclass(frozen=True, slots=True)
class Record:
    """One captured frame.

    Attributes:
        index: position in the file, counting from 0 (skipped records included).
        time_ns: capture timestamp, nanoseconds since the epoch (or since 0 for emulated time).
        data: the captured bytes.
        linktype: LINKTYPE of the interface (1 Ethernet, 227 SocketCAN).
        orig_len: the frame's length on the wire as the capture says (>= len(data)).
        interface: pcapng interface id (0 for pcap).
        comments: pcapng packet comments (opt_comment), e.g. the mark of a deliberately corrupted
            frame written by the emulator.
        if_speed_bps: the interface's ``if_speed`` (pcapng option 8, bits per second); None
            when the capture does not say (classic pcap, no option, or 0).
    """

    index: int
    time_ns: int
    data: bytes
    linktype: int
    orig_len: int
    interface: int = 0
    comments: tuple[str, ...] = ()
    if_speed_bps: int | None = None

    @property
    def frame(self) -> int:
        """Wireshark's frame number (``frame.number``): ``index + 1``."""
        return self.index + 1


PCAP_MAJOR: Final = 2  # the classic pcap version the readers accept (section 4)


@dataclass(frozen=True, slots=True)
class PcapHeader:
    """A classic pcap's global header (draft-ietf-opsawg-pcap section 4), as the readers use it."""

    order: str  # struct byte order of the whole file: "<" or ">"
    ns_per_tick: int  # 1 (nanosecond magic a1b23c4d) or 1000 (microsecond magic a1b2c3d4)
    snaplen: int
    linktype: int  # LinkType, the low 16 bits of the network field (bits 26-31: FCS flags)


def classic_header(head: bytes, name: str) -> PcapHeader:
    """The global header of a classic pcap from its first 24 bytes (both byte orders, both
    magics, version 2 only).

    Raises:
        PcapFormatError: fewer than 24 bytes, another magic, or another major version.
    """
    if len(head) < PCAP_HEADER_BYTES:
        raise PcapFormatError(
            f"{name}: {len(head)} bytes, the pcap header needs {PCAP_HEADER_BYTES}"
        )
    for order in "<>":
        (magic,) = struct.unpack_from(order + "I", head)
        if magic in (MAGIC_US, MAGIC_NS):
            break
    else:
        raise PcapFormatError(
            f"{name}: magic {bytes(head[:4]).hex()} is neither pcap (a1b2c3d4 / a1b23c4d) nor pcapng"
        )
    major, _minor, _zone, _sig, snaplen, network = struct.unpack_from(order + "HHiIII", head, 4)
    if major != PCAP_MAJOR:
        raise PcapFormatError(f"{name}: pcap version {major}, expected {PCAP_MAJOR}")
    return PcapHeader(order, 1 if magic == MAGIC_NS else 1000, snaplen, network & 0xFFFF)


@dataclass(frozen=True, slots=True)
class Skipped:
    """A record that could not be read, with the reason (``code``: the finding ``check`` shows)."""

    index: int
    reason: str
    code: str = "pcap.skipped"

    @property
    def frame(self) -> int:
        """Wireshark's frame number the record would have: ``index + 1``."""
        return self.index + 1


@dataclass(slots=True)
class _Tally:
    """What one pass over a capture found besides the records."""

    records: int = 0
    skipped: list[Skipped] = field(default_factory=list)
    findings: list[FrameFinding] = field(default_factory=list)


class RecordSource(Protocol):
    """What reads like a capture: its records once, in order, then what it counted
    (:class:`Capture` for a file, :class:`skinframes.live_capture.LiveCapture` for an interface)."""

    path: str

    def __iter__(self) -> Iterator[Record]: ...

    @property
    def skipped(self) -> tuple[Skipped, ...]:
        """The records that could not be read."""

    @property
    def findings(self) -> tuple[FrameFinding, ...]:
        """What is wrong in the source but did not cost a record."""

    @property
    def total(self) -> int:
        """Records found: decoded + skipped."""


class FirstRecords:
    """The first ``count`` records of a :class:`RecordSource` (``tshark -c``), itself a record
    source: its skipped records, findings and total are those of what was read (the source is
    closed after the ``count``-th record, as a reader that stops early closes it)."""

    def __init__(self, source: RecordSource, count: int) -> None:
        self.source = source
        self.count = count
        self.path = source.path

    def __iter__(self) -> Iterator[Record]:
        records = iter(self.source)
        try:
            yield from itertools.islice(records, self.count)
        finally:
            close = getattr(records, "close", None)
            if close is not None:
                close()

    @property
    def skipped(self) -> tuple[Skipped, ...]:
        """The source's skipped records, of those read."""
        return self.source.skipped

    @property
    def findings(self) -> tuple[FrameFinding, ...]:
        """The source's findings, of what was read."""
        return self.source.findings

    @property
    def total(self) -> int:
        """Records read: decoded + skipped."""
        return self.source.total


class Capture:
    """A capture file; iterating reads it record by record (see the module docstring).

    Attributes:
        path: the file's name as given (``"<stdin>"`` for a stream).
        format: ``"pcap"`` or ``"pcapng"``, with ``"+gzip"`` when compressed.
    """

    def __init__(
        self,
        path: str,
        format: str,  # the attribute's documented name
        records: tuple[Record, ...] = (),
        skipped: tuple[Skipped, ...] = (),
        *,
        opener: Callable[[], _Source] | None = None,
    ):
        self.path = path
        self.format = format
        self._opener = opener
        self._records: tuple[Record, ...] | None = None if opener else records
        self._tally: _Tally | None = None if opener else _Tally(len(records), list(skipped), [])

    def __iter__(self) -> Iterator[Record]:
        if self._opener is None:
            assert self._records is not None
            yield from self._records
            return
        tally = _Tally()
        source = self._opener()
        try:
            yield from source.records(tally)
        finally:  # also when the reader stops early (closes the iterator): what was read
            source.close()
            tally.skipped.sort(key=lambda s: s.index)
            self._tally = tally

    def _done(self) -> _Tally:
        if self._tally is None:
            for _ in self:  # one pass, holding nothing
                pass
        assert self._tally is not None
        return self._tally

    @property
    def records(self) -> tuple[Record, ...]:
        """Every readable record, in memory (iterate instead for large captures)."""
        if self._records is None:
            self._records = tuple(self)
        return self._records

    @property
    def skipped(self) -> tuple[Skipped, ...]:
        """The records that could not be read, with their reasons."""
        return tuple(self._done().skipped)

    @property
    def findings(self) -> tuple[FrameFinding, ...]:
        """What is wrong in the file but did not cost a record (``check`` reports these)."""
        return tuple(self._done().findings)

    @property
    def total(self) -> int:
        """Records found in the file: decoded + skipped (after an iteration that was stopped
        early, those read until then)."""
        t = self._done()
        return t.records + len(t.skipped)

    def __len__(self) -> int:
        return self._done().records

    def __repr__(self) -> str:
        return f"Capture({self.path!r}, {self.format!r})"


# --- reading ---------------------------------------------------------------------------------------
def read_capture(path: str | Path | IO[bytes]) -> Capture:
    """Open a pcap or pcapng file, gzip-compressed or not, to be read record by record.

    ``path`` may be an open binary stream (standard input: ``sys.stdin.buffer``), read once.
    Only regular files are opened by name: a FIFO or a device (``/dev/zero``) is refused, so
    nothing waits for a writer or reads forever; pipe such input to a stream instead.

    Raises:
        PcapFormatError: the file cannot be opened, is not a regular file, or is not a
            capture (bad magic or header).
    """
    if not isinstance(path, str | Path):
        stream = path
        name = getattr(stream, "name", "<stream>")
        name = name if isinstance(name, str) else "<stream>"
        first = _Source(stream.read, name, closer=None)
        used = False

        def once() -> _Source:
            nonlocal used
            if used:
                raise PcapFormatError(f"{name}: a stream can be read only once")
            used = True
            return first

        return Capture(name, first.format, opener=once)
    name = str(path)
    _check_regular(name)

    def reopen() -> _Source:
        try:
            f = open(name, "rb")  # noqa: SIM115  # closed by _Source.close
        except OSError as exc:
            raise PcapFormatError(f"{name}: cannot read ({exc.strerror or exc})") from exc
        try:
            return _Source(f.read, name, closer=f.close)
        except BaseException:
            f.close()
            raise

    return Capture(name, reopen().closed_format(), opener=reopen)


def iter_capture(path: str | Path | IO[bytes]) -> Iterator[Record]:
    """The records of a capture, streamed: ``iter(read_capture(path))``."""
    return iter(read_capture(path))


def parse_capture(raw: bytes, name: str = "<bytes>") -> Capture:
    """Like :func:`read_capture`, for a file already in memory."""

    def reopen() -> _Source:
        return _Source(io.BytesIO(raw).read, name, closer=None)

    return Capture(name, reopen().format, opener=reopen)


def _check_regular(name: str) -> None:
    try:
        mode = os.stat(name).st_mode
    except OSError as exc:
        raise PcapFormatError(f"{name}: cannot read ({exc.strerror or exc})") from exc
    if stat.S_ISDIR(mode):
        raise PcapFormatError(f"{name}: cannot read (is a directory)")
    if not stat.S_ISREG(mode):
        kind = "a FIFO" if stat.S_ISFIFO(mode) else "a device or special file"
        raise PcapFormatError(
            f"{name}: is {kind}, not a regular file; give its data on standard input ('-')"
        )


class _Input:
    """Bytes from a read function, counted: ``read(n)`` returns n bytes, fewer only at the end."""

    def __init__(self, read: Callable[[int], bytes]):
        self._read = read
        self._buf = b""
        self._off = 0
        self.pos = 0

    def read(self, n: int) -> bytes:
        end = self._off + n
        if end <= len(self._buf):  # the common case: a slice of what is buffered
            out = self._buf[self._off : end]
            self._off = end
            self.pos += n
            return out
        parts = [self._buf[self._off :]]
        have = len(parts[0])
        while have < n:
            chunk = self._read(max(n - have, _CHUNK_BYTES))
            if not chunk:
                break
            parts.append(chunk)
            have += len(chunk)
        self._buf = b"".join(parts)
        out = self._buf[:n]
        self._off = len(out)
        self.pos += len(out)
        return out


class _Gunzip:
    """gzip members (RFC 1952) decompressed as they are read; notes damage and trailing bytes."""

    def __init__(self, read: Callable[[int], bytes], name: str):
        self._read = read
        self._name = name
        self._d = zlib.decompressobj(wbits=31)
        self._pending = b""
        self._fed = 0  # compressed bytes handed to the current member's decompressor
        self._done = 0  # compressed bytes of the members before it
        self.produced = 0
        self.damage = ""
        self.trailing = 0
        self._eof = False

    def _raw(self) -> bytes:
        if self._pending:
            out, self._pending = self._pending, b""
            return out
        return self._read(_CHUNK_BYTES)

    def _used(self) -> int:
        """Compressed bytes the decompressors have consumed so far."""
        d = self._d
        return self._done + self._fed - len(d.unconsumed_tail) - len(d.unused_data)

    def read(self, n: int) -> bytes:
        while not self._eof:
            if self._d.eof:  # a member ended: another member, trailing bytes, or the end
                rest = self._d.unused_data or self._raw()
                while 0 < len(rest) < 2 and (more := self._raw()):
                    rest += more
                if not rest:
                    self._eof = True
                    break
                if rest[:2] != GZIP_MAGIC:
                    self.trailing = len(rest) + self._drain()
                    self._eof = True
                    break
                self._done = self._used()
                self._d = zlib.decompressobj(wbits=31)
                self._fed = 0
                self._pending = rest
                continue
            raw = self._d.unconsumed_tail
            if not raw:
                raw = self._raw()
                self._fed += len(raw)
            if not raw:
                self.damage = "the stream ends before its end-of-stream marker"
                self._eof = True
                break
            try:
                out = self._d.decompress(raw, n)
            except zlib.error as exc:
                self.damage = str(exc)
                self._eof = True
                break
            if out:
                self.produced += len(out)
                if self.produced > GZIP_RATIO_AFTER_BYTES and self.produced > (
                    GZIP_MAX_RATIO * max(self._used(), 1)
                ):
                    raise PcapFormatError(
                        f"{self._name}: gzip stream expands more than {GZIP_MAX_RATIO}:1 "
                        "(a gzip bomb?); refusing to read on"
                    )
                return out
        return b""

    def _drain(self) -> int:
        count = 0
        while chunk := self._read(_CHUNK_BYTES):
            count += len(chunk)
        return count


class _Source:
    """One open capture: its format, checked when opened, and its records when iterated."""

    def __init__(self, read: Callable[[int], bytes], name: str, closer: Callable[[], None] | None):
        self.name = name
        self._closer = closer
        self._gz: _Gunzip | None = None
        head = read(2)
        if head[:2] == GZIP_MAGIC:
            pending = [head]

            def raw(n: int) -> bytes:
                return pending.pop() if pending else read(n)

            self._gz = _Gunzip(raw, name)
            self.input = _Input(self._gz.read)
        else:
            first = [head]

            def plain(n: int) -> bytes:
                return first.pop() if first else read(n)

            self.input = _Input(plain)
        try:
            self._open()
        except BaseException:
            self.close()
            raise

    def closed_format(self) -> str:
        """The format, closing the file (read_capture opens it again to iterate)."""
        self.close()
        return self.format

    def close(self) -> None:
        if self._closer is not None:
            self._closer()
            self._closer = None

    def _open(self) -> None:
        suffix = "+gzip" if self._gz else ""
        magic = self.input.read(4)
        if len(magic) < 4:
            damage = f" (gzip: {self._gz.damage})" if self._gz and self._gz.damage else ""
            raise PcapFormatError(f"{self.name}: {len(magic)} bytes, not a capture file{damage}")
        if magic == PCAPNG_MAGIC:
            self.format = "pcapng" + suffix
            try:
                self._section = self._read_shb(magic)
            except _DamagedBlockError as exc:
                raise PcapFormatError(f"{self.name}: not a readable pcapng ({exc})") from None
        else:
            self.format = "pcap" + suffix
            self._pcap = self._read_pcap_header(magic)

    # --- classic pcap ------------------------------------------------------------------------------
    def _read_pcap_header(self, magic: bytes) -> tuple[str, int, int, int]:
        h = classic_header(magic + self.input.read(PCAP_HEADER_BYTES - 4), self.name)
        return h.order, h.ns_per_tick, h.snaplen, h.linktype

    def _pcap_records(self, tally: _Tally) -> Iterator[Record]:
        order, scale, snaplen, linktype = self._pcap
        rec = struct.Struct(order + "IIII")
        inp = self.input
        index = 0
        while True:
            pos = inp.pos
            head = inp.read(rec.size)
            if not head:
                return
            if len(head) < rec.size:
                tally.skipped.append(
                    Skipped(
                        index, f"truncated record header at byte {pos} ({len(head)} of 16 bytes)"
                    )
                )
                return
            sec, frac, incl, orig = rec.unpack(head)
            if incl > MAX_RECORD_BYTES:
                tally.skipped.append(
                    Skipped(
                        index,
                        f"record at byte {pos} claims {incl} bytes, more than the largest "
                        f"record {MAX_RECORD_BYTES}; rest of file unreadable",
                        "pcap.record_too_long",
                    )
                )
                return
            data = inp.read(incl)
            if len(data) < incl:
                tally.skipped.append(
                    Skipped(
                        index,
                        f"record at byte {pos} claims {incl} bytes, only {len(data)} remain "
                        "(truncated file)",
                    )
                )
                return
            if snaplen and incl > snaplen:  # Wireshark reads it; it should not be there
                tally.findings.append(_over_snaplen(index, incl, snaplen))
            if (scale != 1 and frac >= 1_000_000) or (scale == 1 and frac >= NS_PER_S):
                tally.skipped.append(
                    Skipped(index, f"record at byte {pos}: fraction {frac} out of range")
                )
            else:
                tally.records += 1
                yield Record(index, sec * NS_PER_S + frac * scale, data, linktype, max(orig, incl))
            index += 1

    # --- pcapng ------------------------------------------------------------------------------------
    def _read_shb(self, head: bytes) -> _Section:
        """The Section Header Block whose first 4 bytes are ``head`` (section 4.1)."""
        rest = self.input.read(8)
        where = self.input.pos - 4 - len(rest)
        if len(rest) < 8:
            raise _DamagedBlockError(f"truncated section header block at byte {where}")
        bom = rest[4:]
        if bom == struct.pack("<I", _BYTE_ORDER_MAGIC):
            e = "<"
        elif bom == struct.pack(">I", _BYTE_ORDER_MAGIC):
            e = ">"
        else:
            raise _DamagedBlockError(
                f"section header at byte {where}: byte-order magic {bom.hex()}"
            )
        total = struct.unpack(e + "I", rest[:4])[0]
        body = self._block_body(e, total, 12, where, "section header")
        if len(body) < 12:
            raise _DamagedBlockError(f"section header at byte {where}: {total} bytes, too short")
        major = struct.unpack_from(e + "H", body)[0]
        if major != 1:
            raise _DamagedBlockError(
                f"section header at byte {where}: pcapng version {major}, expected 1"
            )
        return _Section(e)

    def _block_body(self, e: str, total: int, read: int, where: int, what: str) -> bytes:
        """The rest of a block after its first ``read`` bytes, trailing length checked."""
        least = max(12, read + 4)  # a section header has read its byte-order magic already
        if total < least or total % 4 or total > MAX_BLOCK_BYTES:
            why = (
                f"less than {least}"
                if total < least
                else "not a multiple of 4"
                if total % 4
                else f"more than {MAX_BLOCK_BYTES}"
            )
            raise _DamagedBlockError(f"{what} block at byte {where}: length {total}, {why}")
        rest = self.input.read(total - read)
        if len(rest) < total - read:
            raise _DamagedBlockError(
                f"{what} block at byte {where}: {total} bytes, the file ends after "
                f"{read + len(rest)} (truncated)",
                truncated=True,
            )
        trailing = struct.unpack(e + "I", rest[-4:])[0]
        if trailing != total:
            raise _DamagedBlockError(
                f"{what} block at byte {where}: length {total} at the start, {trailing} at the end"
            )
        return rest[:-4]

    def _pcapng_records(self, tally: _Tally) -> Iterator[Record]:
        section = self._section
        inp = self.input
        index = 0
        while True:
            where = inp.pos
            head = inp.read(4)
            if not head:
                return
            try:
                if len(head) < 4:
                    raise _DamagedBlockError(
                        f"block header at byte {where} cut short", truncated=True
                    )
                if head == PCAPNG_MAGIC:
                    section = self._read_shb(head)
                    continue
                e = section.endian
                kind = struct.unpack(e + "I", head)[0]
                length = inp.read(4)
                if len(length) < 4:
                    raise _DamagedBlockError(
                        f"block header at byte {where} cut short", truncated=True
                    )
                total = struct.unpack(e + "I", length)[0]
                body = self._block_body(e, total, 8, where, f"type {kind:#x}")
            except _DamagedBlockError as exc:
                tally.skipped.append(
                    Skipped(
                        index,
                        f"damaged pcapng block: {exc}; rest unreadable",
                        "pcap.truncated" if exc.truncated else "pcapng.block",
                    )
                )
                return
            if kind == _IDB:
                section.interfaces.append(self._interface(e, body, index, tally))
            elif kind in (_EPB, _PB, _SPB):
                rec = self._packet(kind, e, body, index, section, tally)
                if rec is not None:
                    tally.records += 1
                    yield rec
                index += 1

    def _interface(self, e: str, body: bytes, index: int, tally: _Tally) -> _Interface:
        if len(body) < 8:
            tally.findings.append(
                FrameFinding(-1, warning("pcapng.block", "interface block shorter than 8 bytes"))
            )
            return _Interface(0, 0)
        linktype, _res, snaplen = struct.unpack_from(e + "HHI", body)
        iface = _Interface(linktype, snaplen)
        for code, value in _options(e, body, 8, index, "interface", tally):
            if code == _IF_TSRESOL and len(value) == 1:
                v = value[0]
                iface.units_per_s = 2 ** (v & 0x7F) if v & 0x80 else 10**v
            elif code == _IF_TSOFFSET and len(value) == 8:
                iface.offset_s = struct.unpack(e + "q", value)[0]
            elif code == _IF_SPEED and len(value) == 8:
                iface.speed_bps = struct.unpack(e + "Q", value)[0] or None
        return iface

    def _packet(
        self, kind: int, e: str, body: bytes, index: int, section: _Section, tally: _Tally
    ) -> Record | None:
        if kind == _SPB:  # section 4.4: interface 0, no time stamp, length cut to the snaplen
            if len(body) < 4:
                tally.skipped.append(Skipped(index, "simple packet block shorter than 4 bytes"))
                return None
            intid, ts = 0, 0
            orig = struct.unpack_from(e + "I", body)[0]
            incl, start, opt_at = min(orig, len(body) - 4), 4, len(body)
            if section.interfaces and section.interfaces[0].snaplen:
                incl = min(incl, section.interfaces[0].snaplen)
        else:
            if kind == _EPB:
                fmt, start = e + "IIIII", 20
            else:  # obsolete Packet Block: u16 interface, u16 drops
                fmt, start = e + "HHIIII", 20
            if len(body) < start:
                tally.skipped.append(Skipped(index, f"packet block of {len(body)} body bytes"))
                return None
            fields = struct.unpack_from(fmt, body)
            if kind == _EPB:
                intid, high, low, incl, orig = fields
            else:
                intid, _drops, high, low, incl, orig = fields
            ts = (high << 32) | low
            opt_at = start + incl + (-incl % 4)
            if start + incl > len(body):
                tally.skipped.append(
                    Skipped(
                        index,
                        f"packet block: captured length {incl} runs past its block",
                        "pcapng.block",
                    )
                )
                return None
        if incl > MAX_RECORD_BYTES:
            tally.skipped.append(
                Skipped(
                    index,
                    f"record of {incl} bytes, more than the largest record {MAX_RECORD_BYTES}",
                    "pcap.record_too_long",
                )
            )
            return None
        if intid >= len(section.interfaces):
            tally.skipped.append(
                Skipped(index, f"packet block names undescribed interface {intid}")
            )
            return None
        iface = section.interfaces[intid]
        if iface.snaplen and incl > iface.snaplen:
            tally.findings.append(_over_snaplen(index, incl, iface.snaplen))
        comments = tuple(
            value.decode("utf-8", "replace")
            for code, value in _options(e, body, opt_at, index, "packet", tally)
            if code == _OPT_COMMENT
        )
        units = iface.units_per_s
        secs, frac = divmod(ts, units)
        time_ns = (secs + iface.offset_s) * NS_PER_S + frac * NS_PER_S // units
        data = body[start : start + incl]
        return Record(
            index, time_ns, data, iface.linktype, max(orig, incl), intid, comments, iface.speed_bps
        )

    def records(self, tally: _Tally) -> Iterator[Record]:
        """Every record; what could not be read goes to ``tally``."""
        if self.format.startswith("pcapng"):
            yield from self._pcapng_records(tally)
        else:
            yield from self._pcap_records(tally)
        gz = self._gz
        if gz is not None:
            if gz.damage:
                tally.skipped.append(
                    Skipped(
                        tally.records + len(tally.skipped),
                        f"gzip stream damaged ({gz.damage}); records after it are lost",
                        "pcap.gzip",
                    )
                )
            elif gz.trailing:
                tally.findings.append(
                    FrameFinding(
                        -1,
                        warning(
                            "pcap.gzip_trailing",
                            f"{gz.trailing} bytes after the last gzip member (ignored)",
                        ),
                    )
                )


class _DamagedBlockError(Exception):
    """A pcapng block that cannot be read; nothing after it can be trusted."""

    def __init__(self, message: str, truncated: bool = False):
        super().__init__(message)
        self.truncated = truncated


@dataclass(slots=True)
class _Interface:
    """An Interface Description Block (section 4.2) as packets need it."""

    linktype: int
    snaplen: int
    units_per_s: int = _DEFAULT_UNITS_PER_S
    offset_s: int = 0
    speed_bps: int | None = None  # if_speed; None: not given


@dataclass(slots=True)
class _Section:
    """A section's byte order and its interfaces (ids are local to a section)."""

    endian: str
    interfaces: list[_Interface] = field(default_factory=list)


def _options(
    e: str, body: bytes, start: int, index: int, what: str, tally: _Tally
) -> Iterator[tuple[int, bytes]]:
    """The options of a block body from ``start`` (section 3.5); a malformed list is a finding."""
    pos = start
    while pos < len(body):
        if len(body) - pos < 4:
            tally.findings.append(
                _option_finding(index, what, f"{len(body) - pos} bytes left, an option needs 4")
            )
            return
        code, length = struct.unpack_from(e + "HH", body, pos)
        if code == _OPT_ENDOFOPT:
            return
        if pos + 4 + length > len(body):
            tally.findings.append(
                _option_finding(
                    index,
                    what,
                    f"option {code} of {length} bytes runs past the block "
                    f"({len(body) - pos - 4} left)",
                )
            )
            return
        yield code, body[pos + 4 : pos + 4 + length]
        pos += 4 + length + (-length % 4)


def _option_finding(index: int, what: str, text: str) -> FrameFinding:
    where = index if what == "packet" else -1
    return FrameFinding(where, warning("pcapng.option", f"pcapng {what} block: {text}"))


def _over_snaplen(index: int, incl: int, snaplen: int) -> FrameFinding:
    finding: Finding = warning(
        "pcap.caplen_over_snaplen",
        f"captured length {incl} is more than the snap length {snaplen} (read anyway, as "
        "Wireshark does)",
    )
    return FrameFinding(index, finding)
