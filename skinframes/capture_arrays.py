"""A capture's records as numpy columns: the bulk reader behind :func:`taxels_from_capture`.

:func:`iter_record_arrays` maps the file (``mmap``), walks the record headers to find where each
record starts, and hands out every other per-record value as numpy columns computed from those
offsets, block by block: no :class:`~skinframes.pcap.Record` objects, no per-record ``bytes``. A
gzip file cannot be mapped: its blocks come from the record reader, which decompresses as it
goes. The formats are those :mod:`skinframes.pcap` reads:

- classic pcap (draft-ietf-opsawg-pcap section 4-5): the 24-byte file header, then per record
  ts_sec, ts_frac (us or ns by the magic), caplen, origlen and the data; either byte order;
- pcapng (draft-ietf-opsawg-pcapng section 4): Section Header Blocks (byte order per section),
  Interface Description Blocks (LinkType, ``if_tsresol`` option 9, ``if_tsoffset`` option 14),
  Enhanced Packet Blocks, Simple Packet Blocks and the obsolete Packet Block.

Records :mod:`skinframes.pcap` would skip (a fraction out of range, an undescribed interface) are
left out here too; a damaged tail ends the walk, as it ends the record reader.
"""

from __future__ import annotations

import mmap
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Final

import numpy as np
import numpy.typing as npt

from skinframes.capture_writer import (
    BYTE_ORDER_MAGIC,
    NS_PER_S,
    PCAP_HEADER_BYTES,
    SNAPLEN,
)
from skinframes.errors import PcapFormatError
from skinframes.pcap import GZIP_MAGIC, PCAPNG_MAGIC, Record, classic_header, read_capture

__all__ = [
    "BLOCK_BYTES",
    "BLOCK_RECORDS",
    "RecordArrays",
    "iter_record_arrays",
    "read_record_arrays",
    "u16_at",
    "u32_at",
]

PCAP_RECORD_HEADER_BYTES: Final = 16  # ts_sec, ts_frac, caplen, origlen (u32 each)
# pcapng block types (draft-ietf-opsawg-pcapng 4.1-4.4, Appendix A for the obsolete Packet Block)
SHB: Final = 0x0A0D0D0A
IDB: Final = 0x00000001
PB: Final = 0x00000002
SPB: Final = 0x00000003
EPB: Final = 0x00000006
EPB_DATA_OFFSET: Final = 28  # type, length, interface, ts high, ts low, caplen, origlen
SPB_DATA_OFFSET: Final = 12  # type, length, origlen
OPT_IF_TSRESOL: Final = 9
OPT_IF_TSOFFSET: Final = 14
DEFAULT_TSRESOL: Final = 6  # 10^-6 s when an IDB has no if_tsresol


@dataclass(frozen=True, slots=True)
class RecordArrays:
    """Every readable record of a capture, as columns over one byte buffer.

    Attributes:
        data: the file's bytes (uint8, read-only; a memory map for uncompressed files).
        offset: where each record's captured bytes start in ``data`` (int64).
        length: captured bytes of each record (int64).
        time_ns: capture time of each record, ns since the epoch (int64).
        linktype: LINKTYPE of each record's interface (int64).
        index: each record's position in the file, counting records the reader left out.
    """

    data: npt.NDArray[np.uint8]
    offset: npt.NDArray[np.int64]
    length: npt.NDArray[np.int64]
    time_ns: npt.NDArray[np.int64]
    linktype: npt.NDArray[np.int64]
    index: npt.NDArray[np.int64]

    def __len__(self) -> int:
        return int(self.offset.shape[0])


def _view(data: npt.NDArray[np.uint8], dtype: str) -> npt.NDArray[np.int64]:
    """``data`` seen as an integer of ``dtype`` starting at every byte (unaligned, no copy)."""
    size = np.dtype(dtype).itemsize
    count = max(0, data.shape[0] - size + 1)
    return np.ndarray((count,), dtype=dtype, buffer=data, strides=(1,))


def u16_at(
    data: npt.NDArray[np.uint8], at: npt.NDArray[np.int64], big: bool = False
) -> npt.NDArray[np.int64]:
    """The u16 at each offset ``at`` of ``data`` (little-endian unless ``big``), as int64."""
    return _view(data, ">u2" if big else "<u2")[at].astype(np.int64)


def u32_at(
    data: npt.NDArray[np.uint8], at: npt.NDArray[np.int64], big: bool = False
) -> npt.NDArray[np.int64]:
    """The u32 at each offset ``at`` of ``data`` (little-endian unless ``big``), as int64."""
    return _view(data, ">u4" if big else "<u4")[at].astype(np.int64)


def read_record_arrays(path: str | Path) -> RecordArrays:
    """Read a pcap or pcapng file (gzip too) into :class:`RecordArrays`.

    Raises:
        PcapFormatError: the file cannot be read or is not a capture.
    """
    blocks = list(iter_record_arrays(path))
    if all(b.data is blocks[0].data for b in blocks):  # a mapped file: one buffer
        data = blocks[0].data
        shifts = [0] * len(blocks)
    else:  # blocks with bytes of their own (gzip): one buffer of them all
        data = np.concatenate([b.data for b in blocks])
        sizes = [b.data.shape[0] for b in blocks]
        shifts = [sum(sizes[:k]) for k in range(len(blocks))]
    columns = {name: [getattr(b, name) for b in blocks] for name in _COLUMNS}
    columns["offset"] = [o + shift for o, shift in zip(columns["offset"], shifts, strict=True)]
    return RecordArrays(data, *(np.concatenate(columns[name]) for name in _COLUMNS))


_COLUMNS: Final = ("offset", "length", "time_ns", "linktype", "index")
BLOCK_RECORDS: Final = 1 << 16  # records per block of iter_record_arrays (columns: ~3 MiB)


def iter_record_arrays(
    path: str | Path, block_records: int = BLOCK_RECORDS
) -> Iterator[RecordArrays]:
    """:func:`read_record_arrays` block by block: consecutive records, ``block_records`` at a
    time (at least one block, perhaps empty).

    The columns of a block are all that is held. A file is mapped (every block over the same
    ``data``), and the pages of the blocks handed out before the last one are released from this
    process's memory as the next is made (they stay in the page cache, and are read again if
    used again). A gzip capture comes from the record reader (:func:`skinframes.pcap.
    read_capture`, which decompresses as it reads and refuses a gzip bomb), each block with
    its own bytes.

    Raises:
        PcapFormatError: the file cannot be read or is not a capture.
    """
    try:
        with open(path, "rb") as f:
            head = f.read(4)
            if len(head) < 4:
                raise PcapFormatError(f"{path}: {len(head)} bytes, not a capture file")
            if head[:2] == GZIP_MAGIC:
                raw = None
            else:
                raw = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
    except OSError as exc:
        raise PcapFormatError(f"{path}: cannot read ({exc.strerror or exc})") from exc
    if raw is None:  # gzip: the record reader decompresses as it goes (and refuses a bomb)
        yield from _from_records(read_capture(path), block_records)
        return
    data = np.frombuffer(raw, dtype=np.uint8)
    if bytes(raw[:4]) == PCAPNG_MAGIC:
        blocks = _pcapng(raw, data, str(path), block_records)
    else:
        blocks = _pcap(raw, data, str(path), block_records)
    released = 0
    for block in blocks:
        if len(block):
            released = _release(raw, released, int(block.offset[0]) - _RELEASE_MARGIN)
        yield block
    _release(raw, released, len(raw) + mmap.PAGESIZE)  # read to the end: none of it is needed


_RELEASE_MARGIN: Final = 2 << 20  # bytes kept mapped before a block (records read again)
BLOCK_BYTES: Final = 4 << 20  # a block ends after this many bytes of records, or BLOCK_RECORDS
_WALK_AHEAD_BYTES: Final = 4 << 20  # how far the walk of a classic pcap reads ahead


def _release(raw: mmap.mmap, done: int, upto: int) -> int:
    """Drop the pages of ``raw`` in [done, upto) from this process (MADV_DONTNEED: a later
    access reads them again); returns where the released part now ends."""
    upto -= upto % mmap.PAGESIZE
    if upto > done and hasattr(mmap, "MADV_DONTNEED"):
        raw.madvise(mmap.MADV_DONTNEED, done, upto - done)
        return upto
    return done


def _from_records(records: Iterable[Record], block_records: int) -> Iterator[RecordArrays]:
    """Blocks of the record reader's records (each block's bytes joined into its own ``data``):
    for a gzip capture, which cannot be mapped."""
    rows: list[Record] = []
    empty = True
    for rec in records:
        rows.append(rec)
        if len(rows) == block_records:
            yield _block_of(rows)
            rows, empty = [], False
    if rows or empty:
        yield _block_of(rows)


_BLOCK_PAD: Final = 64


def _block_of(rows: list[Record]) -> RecordArrays:
    length = np.array([len(r.data) for r in rows], dtype=np.int64)
    offset = np.concatenate(([0], np.cumsum(length)[:-1])).astype(np.int64)
    # zero bytes after the records: the readers' masked gathers (np.where(ok, at, 0)) may read
    # a few bytes at 0 or past a short record, as they may in a mapped file
    data = np.frombuffer(b"".join([*(r.data for r in rows), bytes(_BLOCK_PAD)]), dtype=np.uint8)
    return RecordArrays(
        data,
        offset[: len(rows)],
        length,
        np.array([r.time_ns for r in rows], dtype=np.int64),
        np.array([r.linktype for r in rows], dtype=np.int64),
        np.array([r.index for r in rows], dtype=np.int64),
    )


def _pcap(
    raw: mmap.mmap, data: npt.NDArray[np.uint8], name: str, block_records: int
) -> Iterator[RecordArrays]:
    header = classic_header(bytes(raw[:PCAP_HEADER_BYTES]), name)
    order, snaplen, scale = header.order, header.snaplen, header.ns_per_tick
    limit = max(snaplen, SNAPLEN)
    big = order == ">"
    first = 0  # records before the block
    empty = True
    for starts in _walk_pcap(raw, order, limit, block_records):
        sec = u32_at(data, starts, big)
        frac = u32_at(data, starts + 4, big)
        length = u32_at(data, starts + 8, big)
        ok = frac < (NS_PER_S if scale == 1 else 1_000_000)
        index = np.flatnonzero(ok).astype(np.int64) + first
        time_ns = sec[ok] * NS_PER_S + frac[ok] * scale
        linktype = np.full(index.shape, header.linktype, dtype=np.int64)
        first += int(starts.shape[0])
        empty = False
        yield RecordArrays(
            data, starts[ok] + PCAP_RECORD_HEADER_BYTES, length[ok], time_ns, linktype, index
        )
    if empty:
        yield _empty(data)


def _empty(data: npt.NDArray[np.uint8]) -> RecordArrays:
    none = np.zeros(0, dtype=np.int64)
    return RecordArrays(data, none, none, none, none, none)


def _walk_pcap(
    raw: mmap.mmap, order: str, limit: int, block_records: int
) -> Iterator[npt.NDArray[np.int64]]:
    """Offsets of the record headers, following the chain of caplen fields, about
    ``block_records`` at a time.

    Each record's position depends on the previous record's caplen, so the chain is walked, but
    mostly in numpy: cyclic captures repeat their record lengths with the cycle, so after a few
    records walked one by one (:func:`_step_pcap`) the lengths' period predicts the next block
    of offsets, and one vectorised read of the caplen fields there keeps the prefix that the
    file confirms (each confirmed caplen makes the next offset true). Where the pattern breaks
    (a fault, a new phase), the walk goes one by one again.
    """
    data = np.frombuffer(raw, dtype=np.uint8)
    big = order == ">"
    end = len(raw)
    head = PCAP_RECORD_HEADER_BYTES
    starts: list[npt.NDArray[np.int64]] = []
    held = 0  # offsets in ``starts``
    recent = np.zeros(0, dtype=np.int64)  # sizes (header + caplen) of the latest records
    pos = PCAP_HEADER_BYTES

    def take(block: npt.NDArray[np.int64]) -> Iterator[npt.NDArray[np.int64]]:
        nonlocal starts, held
        starts.append(block)
        held += int(block.shape[0])
        if held >= block_records or int(block[-1]) - int(starts[0][0]) >= BLOCK_BYTES:
            yield np.concatenate(starts)
            starts, held = [], 0

    while pos + head <= end:
        walked, walked_sizes, pos, stop = _step_pcap(raw, order, limit, pos, _STEP_RECORDS)
        yield from take(walked)
        recent = np.concatenate((recent, walked_sizes))[-2 * _MAX_PERIOD :]
        if stop:
            break
        period = _period(recent)
        block = 4 * period
        while period and pos + head <= end:
            cycle_bytes = int(recent[-period:].sum())  # the walk reads ahead a window at most
            reps = max(1, min(block // period, _WALK_AHEAD_BYTES // max(cycle_bytes, 1)))
            guess = np.tile(recent[-period:], reps)
            at = pos + np.concatenate(([0], np.cumsum(guess[:-1])))
            fits = at + guess <= end
            guess, at = guess[fits], at[fits]
            if not at.size:
                break
            good = u32_at(data, at + 8, big) + head == guess
            m = int(good.size) if bool(good.all()) else int(np.argmin(good))
            if m:
                yield from take(at[:m])
                pos = int(at[m - 1] + guess[m - 1])
                recent = np.concatenate((recent, guess[:m]))[-2 * _MAX_PERIOD :]
            if m < good.size:
                break  # the pattern broke: walk one by one from here
            block = min(2 * block, _BLOCK_RECORDS, block_records)
    if held:
        yield np.concatenate(starts)


_STEP_RECORDS: Final = 256  # records walked one by one before predicting again
_MAX_PERIOD: Final = 1024  # the longest cycle (in records) the prediction looks for
_BLOCK_RECORDS: Final = 1 << 16  # records predicted per vectorised read


def _step_pcap(
    raw: mmap.mmap, order: str, limit: int, pos: int, count: int
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], int, bool]:
    """Walk up to ``count`` records one by one: (offsets, sizes, next offset, damaged tail)."""
    caplen = struct.Struct(order + "I").unpack_from
    end = len(raw)
    head = PCAP_RECORD_HEADER_BYTES
    out: list[int] = []
    out_sizes: list[int] = []
    stop = False
    while len(out) < count and pos + head <= end:
        (incl,) = caplen(raw, pos + 8)
        if incl > limit or pos + head + incl > end:
            stop = True  # a damaged or truncated tail: pcap.py reports it, the columns end here
            break
        out.append(pos)
        out_sizes.append(head + incl)
        pos += head + incl
    return np.array(out, dtype=np.int64), np.array(out_sizes, dtype=np.int64), pos, stop


def _period(sizes: npt.NDArray[np.int64]) -> int:
    """The shortest period of the whole window ``sizes`` (seen at least twice), or 0."""
    n = sizes.shape[0]
    if n < 2:
        return 0
    for candidate in (np.flatnonzero(sizes[::-1][1:] == sizes[-1]) + 1).tolist():
        if 2 * candidate > n:
            break
        if np.array_equal(sizes[candidate:], sizes[:-candidate]):
            return int(candidate)
    return 0


def _pcapng(
    raw: mmap.mmap, data: npt.NDArray[np.uint8], name: str, block_records: int
) -> Iterator[RecordArrays]:
    """Walk the blocks; packets become rows, IDBs give each interface's linktype and clock;
    the rows in blocks of ``block_records``."""
    end = len(raw)
    pos = 0
    rows: list[tuple[int, int, int]] = []  # (block offset, block type, section number)
    sections: list[tuple[str, list[tuple[int, int, int, int]]]] = []  # order, IDBs
    u32 = {"<": struct.Struct("<I").unpack_from, ">": struct.Struct(">I").unpack_from}
    order = "<"
    first = 0  # packet rows before the block
    empty = True
    while pos + 12 <= end:
        if bytes(raw[pos : pos + 4]) == PCAPNG_MAGIC:
            (bom,) = struct.unpack_from("<I", raw, pos + 8)
            order = "<" if bom == BYTE_ORDER_MAGIC else ">"
            sections.append((order, []))
        elif not sections:
            raise PcapFormatError(f"{name}: pcapng without a Section Header Block")
        (kind,) = u32[order](raw, pos)
        (size,) = u32[order](raw, pos + 4)
        if size < 12 or size % 4 or pos + size > end:
            break  # damaged tail
        if kind == IDB:
            sections[-1][1].append(_idb(raw, pos, size, order))
        elif kind in (EPB, SPB, PB):
            rows.append((pos, kind, len(sections) - 1))
            if len(rows) == block_records or pos - rows[0][0] >= BLOCK_BYTES:
                yield _pcapng_rows(data, rows, sections, first)
                first += len(rows)
                rows, empty = [], False
        pos += size
    if not sections:
        raise PcapFormatError(f"{name}: not a readable pcapng")
    if rows or empty:
        yield _pcapng_rows(data, rows, sections, first)


def _pcapng_rows(
    data: npt.NDArray[np.uint8],
    rows: list[tuple[int, int, int]],
    sections: list[tuple[str, list[tuple[int, int, int, int]]]],
    first: int,
) -> RecordArrays:
    """The columns of packet ``rows`` (the ``first``-th packet on), with the sections and
    interfaces described before them."""
    block = np.array([r[0] for r in rows], dtype=np.int64)
    kinds = np.array([r[1] for r in rows], dtype=np.int64)
    section = np.array([r[2] for r in rows], dtype=np.int64)
    n = block.shape[0]
    offset = np.zeros(n, dtype=np.int64)
    length = np.zeros(n, dtype=np.int64)
    time_ns = np.zeros(n, dtype=np.int64)
    linktype = np.zeros(n, dtype=np.int64)
    ok = np.zeros(n, dtype=bool)
    for s, (sec_order, idbs) in enumerate(sections):
        big = sec_order == ">"
        in_s = section == s
        for kind in (EPB, PB, SPB):
            rows_k = np.flatnonzero(in_s & (kinds == kind))
            if not rows_k.size:
                continue
            at = block[rows_k]
            if kind == SPB:
                iface = np.zeros(rows_k.shape, dtype=np.int64)
                orig = u32_at(data, at + 8, big)
                room = u32_at(data, at + 4, big) - SPB_DATA_OFFSET - 4
                length[rows_k] = np.minimum(orig, room)
                offset[rows_k] = at + SPB_DATA_OFFSET
                ts = np.zeros(rows_k.shape, dtype=np.int64)
            else:
                iface = (u32_at if kind == EPB else u16_at)(data, at + 8, big)
                ts = u32_at(data, at + 12, big) << 32 | u32_at(data, at + 16, big)
                length[rows_k] = u32_at(data, at + 20, big)
                offset[rows_k] = at + EPB_DATA_OFFSET
            for i, (lt, resol, tsoffset_s, _) in enumerate(idbs):
                mine = iface == i
                rows_i = rows_k[mine]
                linktype[rows_i] = lt
                time_ns[rows_i] = _ticks_to_ns(ts[mine], resol) + tsoffset_s * NS_PER_S
                ok[rows_i] = True
    index = np.flatnonzero(ok).astype(np.int64) + first
    return RecordArrays(data, offset[ok], length[ok], time_ns[ok], linktype[ok], index)


def _idb(raw: mmap.mmap, pos: int, size: int, order: str) -> tuple[int, int, int, int]:
    """(linktype, if_tsresol byte, if_tsoffset seconds, snaplen) of an Interface Description."""
    linktype, _reserved, snaplen = struct.unpack_from(order + "HHI", raw, pos + 8)
    resol, offset_s = DEFAULT_TSRESOL, 0
    at, stop = pos + 16, pos + size - 4
    while at + 4 <= stop:
        code, n = struct.unpack_from(order + "HH", raw, at)
        if code == 0:
            break
        if code == OPT_IF_TSRESOL and n >= 1:
            resol = raw[at + 4]
        elif code == OPT_IF_TSOFFSET and n == 8:
            (offset_s,) = struct.unpack_from(order + "q", raw, at + 4)
        at += 4 + (n + 3) // 4 * 4
    return linktype, resol, offset_s, snaplen


def _ticks_to_ns(ticks: npt.NDArray[np.int64], resol: int) -> npt.NDArray[np.int64]:
    """Timestamps in if_tsresol units -> ns, floor division as :mod:`skinframes.pcap` does.

    if_tsresol: bit 7 clear, 10^-v s per tick; bit 7 set, 2^-v s (pcapng 4.2, option 9).
    """
    v = resol & 0x7F
    if resol & 0x80:
        whole = ticks >> v
        part = ticks & ((1 << v) - 1)
        out: npt.NDArray[np.int64] = whole * NS_PER_S + (part * NS_PER_S >> v)
    elif v <= 9:
        out = ticks * 10 ** (9 - v)
    else:
        out = ticks // 10 ** (v - 9)
    return out
