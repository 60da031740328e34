"""The records of a plain classic pcap file, fast: what ``check`` and ``analyze`` read.

A plain classic pcap (draft-ietf-opsawg-pcap sections 4-5: uncompressed, every record whole,
caplen within the snap length and :data:`~skinframes.pcap.MAX_RECORD_BYTES`, the fraction in
range) is the common case, and there :mod:`skinframes.pcap`'s reader has nothing to report: no
skipped record, no finding, interface 0, no comments, no interface speed. :func:`iter_plain_pcap` reads such a file
in large chunks (memory bounded by the chunk, as the reader's) and yields each record as a
:data:`RecordRow`, a tuple of :class:`~skinframes.pcap.Record`'s fields and values, about five
times cheaper to make than a ``Record``. Where the reader would skip a record or
note a finding, it raises :class:`NotPlainError` instead, and the caller starts again with
:func:`~skinframes.pcap.read_capture` (tests/skinframes/test_fast_paths.py compares both).
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import BinaryIO, Final, TypeAlias

from skinframes.capture_writer import NS_PER_S, PCAP_HEADER_BYTES
from skinframes.errors import PcapFormatError
from skinframes.pcap import MAX_RECORD_BYTES, Record, classic_header

__all__ = ["NotPlainError", "RecordRow", "iter_plain_pcap", "record_rows"]

CHUNK_BYTES: Final = 1 << 16  # read at a time (the reader's too); a longer record is read whole
RECORD_HEADER_BYTES: Final = 16  # ts_sec, ts_frac, caplen, origlen (u32 each), section 5
_US_PER_S: Final = 1_000_000


class NotPlainError(Exception):
    """The file is not (or stops being) a plain classic pcap: read it with ``read_capture``."""


# (index, time_ns, data, linktype, orig_len, interface, comments, if_speed_bps): a Record's
# fields, in order
RecordRow: TypeAlias = tuple[int, int, bytes, int, int, int, tuple[str, ...], int | None]


def record_rows(records: Iterable[Record]) -> Iterator[RecordRow]:
    """The reader's records as rows, so that one loop reads both."""
    for r in records:
        yield (
            r.index,
            r.time_ns,
            r.data,
            r.linktype,
            r.orig_len,
            r.interface,
            r.comments,
            r.if_speed_bps,
        )


def iter_plain_pcap(path: str | Path) -> Iterator[RecordRow]:
    """Every record of a plain classic pcap, streamed.

    Raises:
        NotPlainError: not a classic pcap, or at the first record the reader would skip or
            note (truncated, too long, past the snap length, fraction out of range).
        OSError: the file cannot be read.
    """
    f = open(path, "rb")  # noqa: SIM115  # closed by _records when it ends
    try:
        header = classic_header(f.read(PCAP_HEADER_BYTES), str(path))
    except PcapFormatError as e:
        f.close()
        raise NotPlainError(str(e)) from e
    except BaseException:
        f.close()
        raise
    return _records(f, header.order, header.ns_per_tick == 1, header.snaplen, header.linktype)


def _records(f: BinaryIO, order: str, ns: bool, snaplen: int, linktype: int) -> Iterator[RecordRow]:
    """The records after the file header (section 5), chunk by chunk; closes ``f``."""
    read = f.read
    with f:
        unpack_from = struct.Struct(order + "IIII").unpack_from
        scale, frac_limit = (1, NS_PER_S) if ns else (1000, _US_PER_S)
        limit = min(snaplen, MAX_RECORD_BYTES) if snaplen else MAX_RECORD_BYTES
        buf: bytes = read(CHUNK_BYTES)
        have = len(buf)
        pos = 0
        index = 0
        while True:
            if pos + RECORD_HEADER_BYTES > have:
                more = read(CHUNK_BYTES)
                if not more:
                    if pos < have:
                        raise NotPlainError("truncated record header")
                    return
                buf = buf[pos:] + more
                have, pos = len(buf), 0
                continue
            sec, frac, incl, orig = unpack_from(buf, pos)
            if incl > limit or frac >= frac_limit:
                raise NotPlainError(f"record {index}: the reader skips or notes it")
            start = pos + RECORD_HEADER_BYTES
            end = start + incl
            if end > have:
                more = read(max(CHUNK_BYTES, end - have))
                if not more:
                    raise NotPlainError("truncated record")
                buf = buf[pos:] + more
                have, pos = len(buf), 0
                continue
            time_ns = sec * NS_PER_S + frac * scale
            yield (
                index,
                time_ns,
                buf[start:end],
                linktype,
                orig if orig > incl else incl,
                0,
                (),
                None,
            )
            pos = end
            index += 1
