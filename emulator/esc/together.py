"""What one frame does at many ESCs at once: logical datagrams over numpy rows.

The commit of a frame's register writes, at one ESC or many, is
:func:`emulator.esc.device.commit_together` (over the rows of the ESCs' memory; a single ESC
commits as a line of one); it and :func:`~emulator.esc.device.finish_together` are re-exported
here under their old names.

A logical datagram (LRD, LWR, LRW) that ESCs with the same FMMU plan cut map onto plain memory
(:meth:`EscDevice._access`) is done for all of them at once by :func:`logical_together`:
hostile FMMUs, bit-wise ones among them, cost the ESCs one pass over rows instead of big-integer
arithmetic ESC by ESC. (Reads of DL or AL status among them are of the committed bytes; the
events they clear are the caller's, :meth:`EscDevice._clear_read_events`, and so is bringing DC
registers up to the frame's time before, :meth:`EscDevice._refresh_dc`; writes of registers go
among each ESC's shadow writes.)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.esc.commands import LRD, LWR
from emulator.esc.device import (
    TOGETHER_MIN,
    EscDevice,
    commit_together,
    consecutive,
    finish_together,
)
from emulator.esc.mapping import (
    LogicalOp,
    LogicalPlan,
)
from emulator.esc.registers import (
    REG_RESET_ECAT,
    REGISTER_END,
)
from emulator.esc.write_plans import write_masked

# ESCs in a row with one plain logical plan from which rows beat each ESC on its own
LOGICAL_TOGETHER_MIN: Final = 8
_Rows = npt.NDArray[np.intp]

__all__ = [
    "LOGICAL_TOGETHER_MIN",
    "TOGETHER_MIN",
    "commit_together",
    "finish_together",
    "logical_together",
]


def logical_together(
    memory: npt.NDArray[np.uint8],
    rows: Sequence[int],
    plan: LogicalPlan,
    cmd: int,
    buf: bytearray,
    off: int,
    n: int,
    shadow: Sequence[LogicalOp] = (),
    devices: Sequence[EscDevice] = (),
) -> int:
    """A logical datagram (data ``buf[off:off+n]``, in place) through the ESCs of ``rows`` in
    chain order, each of which maps it onto plain memory with ``plan``, a plan cut
    (:attr:`emulator.esc.mapping.Access.cut`), as :meth:`EscDevice._logical` at each in turn
    would do it but for the events its reads of DL or AL status clear (the caller's): the
    working counter's increment. The register bytes its write parts ``shadow``
    (:attr:`emulator.esc.mapping.Access.shadow`) write go among the shadow writes of
    ``devices`` (the ESCs of ``rows``; :meth:`EscDevice._write_shadow`), alike at every ESC
    where they are alike.

    An ESC reads before it writes, and its write takes the data as it arrived (datasheet I
    Table 7). Its reads replace the same frame bits at every ESC, so the data arriving at an
    ESC is the first ESC's with those bits from the previous ESC's memory, as it was: every
    ESC's read and write follow from the memory before the datagram, one array operation per
    part of the plan for all the ESCs. The frame leaves with the last ESC's reads; a write
    of frame bytes that no part reads takes the data as it arrived, alike at every ESC: one
    row, shifted once, for all (every write of an LWR).
    """
    reads, writes = plan
    m = len(rows)
    at = consecutive(np.asarray(rows, np.intp))
    arrived = np.frombuffer(buf, np.uint8, n, off)[None, :]
    if reads:  # the frame leaves with the last ESC's reads
        out = arrived.copy()
        _read_rows(memory, slice(rows[-1], rows[-1] + 1), reads, out)
    read = [(op.at, op.at + op.width) for op in reads]
    met = [  # per write (and shadow write), whether a read replaces some of its frame bytes
        any(x < hi and y > lo for x, y in read)
        for lo, hi in ((op.at, op.at + op.width) for op in (*writes, *shadow))
    ]
    data_in = arrived  # the frame bytes no ESC reads arrive alike at every ESC: one row
    if any(met):  # per ESC, the data as it arrived there, from the memory before any write
        left = np.repeat(arrived, m, axis=0)  # the data as each ESC leaves it
        _read_rows(memory, at, reads, left)
        data_in = np.concatenate((arrived, left[:-1]))
    if shadow:  # the registers as committed: no write of the datagram reaches them
        _shadow_rows(memory, at, shadow, met[len(writes) :], arrived, data_in, devices)
    for (bytewise, phys, size, shift, mask, start, width), varies in zip(
        writes, met[: len(writes)], strict=True
    ):
        src = data_in if varies else arrived
        if bytewise:
            memory[at, phys : phys + size] = src[:, start : start + size]
        else:
            new = _shifted(src[:, start : start + width], -shift, size)
            write_masked(memory, at, phys, phys + size, new, _mask(mask, size))
    if reads:
        buf[off : off + n] = out[0].tobytes()
    r, w = int(bool(reads)), int(bool(writes))
    return m * (r if cmd == LRD else w if cmd == LWR else r + 2 * w)


def _shadow_rows(
    memory: npt.NDArray[np.uint8],
    at: _Rows | slice,
    shadow: Sequence[LogicalOp],
    varies: Sequence[bool],
    arrived: npt.NDArray[np.uint8],
    data_in: npt.NDArray[np.uint8],
    devices: Sequence[EscDevice],
) -> None:
    """What the write parts ``shadow`` put among the shadow writes of each of ``devices``
    (whose memory is ``memory[at]``; :meth:`EscDevice._write_shadow`): the bytes each writes
    below 0x0F80, a bit-wise part's merged with the registers as committed (what
    :meth:`EscDevice._write` takes of them, datasheet I 3.4); from the data as it arrived,
    ``arrived`` where no read replaces their frame bytes (``varies``), else ``data_in`` (a row
    per ESC); one (address, bytes) for all where the bytes are alike."""
    for (bytewise, a, size, shift, bits, start, width), per_row in zip(shadow, varies, strict=True):
        src = data_in if per_row else arrived
        if bytewise:  # physical a
            written = src[:, start : start + min(size, REGISTER_END - a)]
        else:
            k = min(size, REGISTER_END - a)  # the register bytes: the shift's low k bytes alone
            mask = _mask(bits, size)[:k]
            new = _shifted(src[:, start : start + width], -shift, k)
            written = (memory[at, a : a + k] & ~mask) | (new & mask)
        resets = a <= REG_RESET_ECAT < a + written.shape[1]  # each ESC counts its reset byte
        if len(written) == 1 or (written == written[0]).all():
            entry = (a, written[0].tobytes())
            if resets:
                for dev in devices:
                    dev._write_shadow((entry,))
            else:  # what write_shadow does there: the entry among each ESC's shadow writes
                one = [entry]  # (one object for all: compiled, a tuple appended is boxed anew)
                for dev in devices:
                    dev.pending.extend(one)
        elif resets:
            for dev, row in zip(devices, written, strict=True):
                dev._write_shadow(((a, row.tobytes()),))
        else:  # what write_shadow does there: each ESC's row among its shadow writes
            k = written.shape[1]
            blob = written.tobytes()
            for i, dev in enumerate(devices):
                dev.pending.append((a, blob[i * k : i * k + k]))


def _read_rows(
    memory: npt.NDArray[np.uint8],
    rows: _Rows | slice,
    reads: Sequence[LogicalOp],
    left: npt.NDArray[np.uint8],
) -> None:
    """The parts ``reads`` of a plan (cut) read from the memory of ``rows`` into ``left``, the
    datagram's data as it arrived at each of them (a row each)."""
    for bytewise, phys, size, shift, mask, at, width in reads:
        if bytewise:
            left[:, at : at + size] = memory[rows, phys : phys + size]
        else:
            new = _shifted(memory[rows, phys : phys + size], shift, width)
            write_masked(left, slice(None), at, at + width, new, _mask(mask, width))


def _shifted(data: npt.NDArray[np.uint8], shift: int, width: int) -> npt.NDArray[np.uint8]:
    """Row by row, the ``width`` low bytes of the little-endian integer in ``data`` shifted
    right by ``shift`` bits (left when negative): ``(int.from_bytes(row, "little") >> shift)``
    as bytes, zeros shifted in (a view of ``data`` for a shift by whole bytes within it)."""
    q, r = divmod(shift, 8)  # shift = 8q + r, 0 <= r < 8
    rows, length = data.shape
    need = width + (r != 0)  # moved[:, i] = data[:, i + q] or 0, for i < need
    if q >= 0 and q + need <= length:
        moved = data[:, q : q + need]
    else:
        moved = np.zeros((rows, need), np.uint8)
        lo, hi = max(0, -q), min(need, length - q)
        if lo < hi:
            moved[:, lo:hi] = data[:, lo + q : hi + q]
    if r == 0:
        return moved
    out = moved[:, :width] >> np.uint8(r)
    # the left shift as a product (bits above 8 fall away alike): numpy shifts uint8 left
    # element by element, about ten times slower than it multiplies them
    out |= moved[:, 1:] * np.uint8(1 << (8 - r))
    return out


def _mask(bits: int, width: int) -> npt.NDArray[np.uint8]:
    """An integer mask as ``width`` little-endian bytes."""
    return np.frombuffer(bits.to_bytes(width, "little"), np.uint8)
