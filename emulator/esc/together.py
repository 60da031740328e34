"""What one frame does at many ESCs at once: the commit of equal register writes, as numpy rows.

A broadcast write (BWR, and the writing side of ARMW/FRMW) leaves the same (address, data) in
the shadow registers of every ESC it reaches; at the end of the frame each of them commits it
(datasheet I 3.4). :func:`commit_together` does what :meth:`EscDevice.end_frame` does to the
registers, for all of them in one pass over the rows of the chain's memory
(:attr:`emulator.esc.chain.EcatChain.memory`, one ESC a row): each write is cut and masked once
(the cut every ESC of a configuration shares), and what differs between the ESCs
(the SyncManagers enabled before the frame, who owns the EEPROM interface, whose FMMU or
SyncManager table changed) is a mask of rows. DL status after a write of DL control, the event
request and the DC system time compare (:func:`emulator.esc.dc.compare_together`) are worked out
over the rows too, and so are changed SyncManager tables: decoded, and what they change worked
out, once per distinct table before and after (:func:`emulator.esc.mapping.sm_change`), each
ESC then only changing its SyncManager objects. What else follows a commit
(:meth:`EscDevice.take_effect`) goes step by step over all the ESCs: changed FMMU tables decoded
once per distinct bytes, DC configuration, the event request over the rows, an EEPROM command
where ECAT owns the interface, AL control; and the end of the frame
(:func:`finish_together`) asks only the ESCs with a buffer or reset to finish. The work thus
grows with the bytes written and the ESCs whose state the write changes, not with one Python
pass per ESC and byte range. Tests hold the result equal to the ESC-by-ESC commit under
hostile frames.

A logical datagram (LRD, LWR, LRW) that ESCs with the same FMMU plan cut map onto plain memory
(:meth:`EscDevice.row_access`) is done for all of them at once by :func:`logical_together`:
hostile FMMUs, bit-wise ones among them, cost the ESCs one pass over rows instead of big-integer
arithmetic ESC by ESC. (Reads of DL or AL status among them are of the committed bytes; the
events they clear are the caller's, :meth:`EscDevice.clear_read_events`, and so is bringing DC
registers up to the frame's time before, :meth:`EscDevice.refresh_dc`; writes of registers go
among each ESC's shadow writes.)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.esc.commands import LRD, LWR
from emulator.esc.dc import REG_DC_RECEIVE, compare_together, configure_together
from emulator.esc.device import (
    EscDevice,
    config_area,
    config_writes,
    eeprom_read,
    port1_forwarding,
)
from emulator.esc.mapping import (
    LogicalOp,
    LogicalPlan,
    PlainAccess,
    fmmu_table,
    sm_change,
    sm_table,
)
from emulator.esc.registers import (
    DL_PDI_OPERATIONAL,
    DL_PORT0,
    DL_PORT1_CLOSED,
    DL_PORT1_LINK,
    DL_PORTS_2_3_CLOSED,
    EE_ACK_ERROR,
    EE_CHECKSUM_ERROR,
    EE_CMD_READ,
    EE_CMD_RELOAD,
    EE_CMD_WRITE,
    EE_NOT_LOADED,
    EE_WRITE_ENABLE,
    EE_WRITE_ENABLE_ERROR,
    EVENT_DL_STATUS,
    REG_AL_CONTROL,
    REG_DL_CONTROL,
    REG_DL_STATUS,
    REG_ECAT_EVENT,
    REG_ECAT_EVENT_MASK,
    REG_EEPROM_ADDRESS,
    REG_EEPROM_CONFIG,
    REG_EEPROM_CONTROL,
    REG_EEPROM_DATA,
    REG_EEPROM_PDI,
    REG_ERROR_COUNTERS,
    REG_FMMU,
    REG_PDI_CONTROL,
    REG_PU_ERRORS,
    REG_RESET_ECAT,
    REG_SM,
    REGISTER_END,
    SM_BYTES,
    SM_NO_BUFFER,
)
from emulator.esc.write_plans import TOUCHES_FMMU, TOUCHES_SM, mark

__all__ = [
    "LOGICAL_TOGETHER_MIN",
    "TOGETHER_MIN",
    "commit_together",
    "finish_together",
    "last_readers",
    "logical_together",
    "lrd_last_readers",
]

TOGETHER_MIN: Final = 4  # ESCs with equal writes from which one pass over rows beats one by one
LOGICAL_TOGETHER_MIN: Final = 8  # ESCs with one plain logical plan from which rows beat one by one
_Rows = npt.NDArray[np.intp]
# bytes a row from which _masked writes a run of whole bytes straight and masks only its ends:
# that saves passes over the bytes, but takes four more accesses of the rows, dearer for fewer
_WIDE: Final = 256


def commit_together(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    *,
    alike: bool = True,
) -> None:
    """Commit the pending register writes of ``devices`` (one configuration), whose memory is
    ``memory[rows]``, as each one's :meth:`EscDevice.end_frame` would (before
    :meth:`EscDevice.finish_frame`): equal lists, or with ``alike`` False lists of writes at the
    same addresses and lengths whose bytes differ from ESC to ESC (a logical datagram's through
    FMMUs that map each ESC's own frame bytes onto registers), each write then a row of bytes
    per ESC."""
    plans = devices[0].write_plans
    masks = plans.mask_array
    first = devices[0].pending
    datas: list[npt.NDArray[np.uint8]] = []
    for j, (_, written) in enumerate(first):
        if alike:
            datas.append(np.frombuffer(written, np.uint8))
        else:
            blob = b"".join([dev.pending[j][1] for dev in devices])
            datas.append(np.frombuffer(blob, np.uint8).reshape(len(devices), len(written)))
    pending = [(addr, plans.plan(addr, len(written))) for addr, written in first]
    for dev in devices:
        dev.pending.clear()
    touched = 0
    for _, (_, touches) in pending:
        touched |= touches
    every = _every(rows)
    sm_before = memory[every, REG_SM : plans.sm_end].copy() if touched & TOUCHES_SM else None
    fmmu_before = (
        memory[every, REG_FMMU : plans.fmmu_end].copy() if touched & TOUCHES_FMMU else None
    )
    enabled = sm_before[:, 6::SM_BYTES] if sm_before is not None else None  # bit 0
    flags = [False] * 5  # AL control, EEPROM command, DL control, FMMU, SM written
    eeprom = np.zeros(len(rows), np.bool_)
    dc: tuple[int, int] | None = None
    for (addr, (segments, _)), values in zip(pending, datas, strict=True):
        for lo, hi, mask, marks in segments:
            part = values[..., lo - addr : hi - addr]  # one row, or one per ESC
            if mask < 0:  # a register with side effects
                _special(devices, memory, rows, lo, hi, part, enabled, masks, flags, eeprom)
            elif mask:
                _masked(memory, every, lo, hi, part, masks[lo:hi])
                if marks:
                    dc = mark(lo, hi, flags, plans.fmmu_end, dc)
    al, _, dl, fmmu, sm = flags
    # what EscDevice.take_effect then does, in its order, step by step over all the ESCs
    if fmmu and fmmu_before is not None:  # changed FMMU tables
        changed = (memory[every, REG_FMMU : plans.fmmu_end] != fmmu_before).any(axis=1)
        _fmmus(devices, memory, rows, np.flatnonzero(changed).tolist(), plans.fmmu_end)
    if sm and sm_before is not None and enabled is not None:  # changed SyncManager tables
        changed = (memory[every, REG_SM : plans.sm_end] != sm_before).any(axis=1)
        _syncmanagers(devices, memory, rows, np.flatnonzero(changed).tolist(), enabled)
    if dl:
        _dl_status(devices, memory, rows)
    if dc is not None:
        configure_together([dev.dc for dev in devices], memory, rows, *dc)
    events = memory[every, REG_ECAT_EVENT : REG_ECAT_EVENT + 2].astype(np.int64)
    enable = memory[every, REG_ECAT_EVENT_MASK : REG_ECAT_EVENT_MASK + 2].astype(np.int64)
    irqs = ((events[:, 0] | events[:, 1] << 8) & (enable[:, 0] | enable[:, 1] << 8)).tolist()
    for dev, irq in zip(devices, irqs, strict=True):
        dev.irq = irq  # what EscDevice.update_irq sets
    if eeprom.any():
        _eeprom_commands(devices, memory, rows, np.flatnonzero(eeprom))
    if al:
        value = memory[every, REG_AL_CONTROL].astype(np.int64)
        value |= memory[every, REG_AL_CONTROL + 1].astype(np.int64) << 8
        control = memory[every, REG_PDI_CONTROL + 1].tolist()
        EscDevice.al_control_together(devices, value.tolist(), control)


def _every(rows: _Rows) -> _Rows | slice:
    """``rows`` (ascending, distinct), or the slice of them where they are consecutive: views
    of the memory instead of copies, assignments without fancy indexing (a few us less each)."""
    if len(rows) and rows[-1] - rows[0] == len(rows) - 1:
        return slice(int(rows[0]), int(rows[-1]) + 1)
    return rows


def _eeprom_commands(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    which: npt.NDArray[np.intp],
) -> None:
    """:meth:`EscDevice.eeprom_command` at ``devices[i]`` for ``i`` in ``which`` (ECAT owns
    the interface there and wrote 0x0502): the command bits and write enable self-clear, no
    command clears the error bits, an invalid one sets the acknowledge error (datasheet I
    11.2.3), over the rows; a read, write or reload at each ESC, which has its EEPROM."""
    at = rows[which]
    control = memory[at, REG_EEPROM_CONTROL].astype(np.int64)
    control |= memory[at, REG_EEPROM_CONTROL + 1].astype(np.int64) << 8
    command = (control >> 8) & 0x07
    status = control & ~(0x0700 | EE_WRITE_ENABLE)
    nothing = command == 0
    each = (command == EE_CMD_READ) | (command == EE_CMD_WRITE) | (command == EE_CMD_RELOAD)
    status = np.where(nothing, status & ~(EE_ACK_ERROR | EE_WRITE_ENABLE_ERROR), status)
    status = np.where(nothing | each, status, status | EE_ACK_ERROR)
    reload, read = command == EE_CMD_RELOAD, command == EE_CMD_READ
    if read.sum() >= TOGETHER_MIN:
        status[read] = _reads(devices, memory, at[read], which[read].tolist(), status[read])
        each &= ~read
    here = ~each
    memory[at[here], REG_EEPROM_CONTROL] = status[here] & 0xFF
    memory[at[here], REG_EEPROM_CONTROL + 1] = status[here] >> 8
    if reload.sum() >= TOGETHER_MIN:
        _reloads(devices, memory, at[reload], which[reload].tolist(), status[reload])
        each &= ~reload
    for i in which[each].tolist():
        devices[i].eeprom_command()


def _reads(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    which: list[int],
    status: npt.NDArray[np.int64],
) -> npt.NDArray[np.int64]:
    """The read command of :meth:`EscDevice.eeprom_command` at ``devices[i]`` for ``i`` in
    ``which`` (memory ``rows``, EEPROM control and status with the command cleared
    ``status``): 8 bytes from the word address 0x0504 into 0x0508 (a sequential read wraps
    around the EEPROM's end), or the acknowledge error at an address beyond it (datasheet I
    11.2.3); each ESC's bytes from its own EEPROM, into the rows at once. The status is
    returned."""
    address = memory[rows, REG_EEPROM_ADDRESS : REG_EEPROM_ADDRESS + 4].copy().view("<u4")
    read: list[bytearray] = []
    beyond: list[int] = []  # no EEPROM answers beyond its size
    for k, (i, word) in enumerate(zip(which, address[:, 0].tolist(), strict=True)):
        got = eeprom_read(devices[i].sii, word)
        if got is None:
            beyond.append(k)
        else:
            read.append(got)
    if beyond:
        status = status.copy()
        status[beyond] |= EE_ACK_ERROR
        rows = np.delete(rows, beyond)
    data = np.frombuffer(b"".join(read), np.uint8).reshape(len(read), 8)
    memory[rows, REG_EEPROM_DATA : REG_EEPROM_DATA + 8] = data
    return status


def _reloads(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    which: list[int],
    status: npt.NDArray[np.int64],
) -> None:
    """The reload command of :meth:`EscDevice.eeprom_command` at ``devices[i]`` for ``i`` in
    ``which`` (memory ``rows``, EEPROM control and status with the command cleared ``status``):
    configuration area A (SII words 0-7, :func:`config_area`) into the registers, as
    :meth:`EscDevice._load_config_area` does at a later load (datasheet I 11.1, Table 42), over
    the rows of the ESCs whose SII has the same words 0-7."""
    alike: dict[bytes, list[int]] = {}
    for k, i in enumerate(which):
        alike.setdefault(bytes(devices[i].sii[:16]), []).append(k)
    for head, ks in alike.items():
        at, value = rows[ks], status[ks]
        words = config_area(head)
        if words is None:
            value = value | EE_CHECKSUM_ERROR | EE_NOT_LOADED
        else:
            value = value & ~(EE_CHECKSUM_ERROR | EE_NOT_LOADED)
            esc_config = memory[at, REG_PDI_CONTROL + 1] & 0xF2  # link detection: first load only
            for addr, data in config_writes(words):
                memory[at, addr : addr + len(data)] = np.frombuffer(data, np.uint8)
            memory[at, REG_PDI_CONTROL + 1] = esc_config | ((words[0] >> 8) & ~0xF2 & 0xFF)
        memory[at, REG_EEPROM_CONTROL] = value & 0xFF
        memory[at, REG_EEPROM_CONTROL + 1] = value >> 8


def finish_together(
    devices: Sequence[EscDevice], memory: npt.NDArray[np.uint8], rows: _Rows
) -> None:
    """:meth:`EscDevice.finish_frame` of ``devices``, whose memory is ``memory[rows]``, after
    :func:`commit_together`: 0x0040 shows no reset under way at every row, and the ESCs with
    more to finish (:meth:`EscDevice.unfinished`) finish the frame (:meth:`EscDevice.finish_frames`)."""
    memory[_every(rows), REG_RESET_ECAT] = 0
    EscDevice.finish_frames(EscDevice.unfinished(devices))


def _fmmus(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    which: Sequence[int],
    end: int,
) -> None:
    """The FMMUs of ``devices[i]`` for ``i`` in ``which`` after a frame changed their registers
    [0x0600, ``end``): each table decoded once per distinct bytes (:func:`fmmu_table`), as
    :meth:`EscDevice.take_effect` does ESC by ESC."""
    if not which:
        return
    width = end - REG_FMMU
    tables = memory[rows[list(which)], REG_FMMU:end].tobytes()
    for k, i in enumerate(which):
        devices[i].use_fmmus(fmmu_table(tables[k * width : (k + 1) * width]))


def _syncmanagers(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    which: Sequence[int],
    enabled: npt.NDArray[np.uint8],
) -> None:
    """What :meth:`EscDevice.take_effect` does first to the ESCs ``devices[i]`` for ``i`` in
    ``which`` after a frame changed their SyncManager registers (the rest of it, which an FMMU,
    DC, EEPROM or AL control write sets off, does not touch the SyncManagers, and follows):
    their tables decoded and the changes worked out (:func:`sm_table`, :func:`sm_change`) once
    per distinct table before, table after and activate bytes before the frame (``enabled``, a
    row each), each change's status registers set over the rows at once, and each ESC's
    SyncManagers changed as the change says (:meth:`EscDevice.change_syncmanagers_together`); the
    mailbox handler runs once the frame has passed. An ESC whose table and activate bytes equal
    those of the ESC before it (compared over the rows), with the same table before, joins its
    group without a key of its own."""
    if not which:
        return
    count = enabled.shape[1]
    width = SM_BYTES * count
    at = list(which)
    block = np.concatenate((memory[rows[at], REG_SM : REG_SM + width], enabled[at]), axis=1)
    differs = np.ones(len(at), np.bool_)
    differs[1:] = (block[1:] != block[:-1]).any(axis=1)
    held = [devices[i].sm_areas for i in at]
    starts = [  # where a run of ESCs with equal bytes and the same table before starts
        k
        for k, (new, mine, last) in enumerate(
            zip(differs.tolist(), held, [None, *held[:-1]], strict=True)
        )
        if new or mine is not last
    ]
    stride = width + count
    data = block.tobytes()
    groups: dict[tuple[int, bytes], list[int]] = {}
    for k, end in zip(starts, [*starts[1:], len(at)], strict=True):
        groups.setdefault((id(held[k]), data[k * stride : (k + 1) * stride]), []).extend(at[k:end])
    for (_, key), members in groups.items():
        table, before = key[:width], key[width:]
        areas = devices[members[0]].sm_areas  # the same object at each of them
        found = sm_table(table)
        if found[0] != areas:
            change = sm_change(areas, before, found)
            if change[0]:
                memory[rows[members][:, None], np.array(change[0], np.intp)] = SM_NO_BUFFER
            EscDevice.change_syncmanagers_together([devices[i] for i in members], change, found[0])
        else:
            EscDevice.sm_registers_written_together([devices[i] for i in members])


# port1_forwarding by DL control bits 10-11 and the port 1 link (False, True): one lookup an ESC
_FORWARDING: Final = tuple(
    (port1_forwarding(setting, False), port1_forwarding(setting, True)) for setting in range(4)
)


def _dl_status(devices: Sequence[EscDevice], memory: npt.NDArray[np.uint8], rows: _Rows) -> None:
    """:meth:`EscDevice._update_dl_status` at every row, after a write of DL control: DL status
    0x0110 from the PDI, the port 1 link and the loop setting (datasheet II 2.4.3, Table 2), the
    DL status event where it changed, and each ESC's forwarding and source MAC marking."""
    setting = ((memory[rows, REG_DL_CONTROL + 1] >> 2) & 0x03).tolist()
    marks = (memory[rows, REG_DL_CONTROL] & 0x01).astype(np.bool_).tolist()
    links = [dev.port1_link for dev in devices]
    onwards = [_FORWARDING[s][link] for s, link in zip(setting, links, strict=True)]
    for dev, onward, mac in zip(devices, onwards, marks, strict=True):
        dev.onward, dev.sets_mac = onward, mac
    link = np.array(links, np.bool_)
    pdi = np.array([dev.pdi_operational for dev in devices], np.bool_)
    closed = np.array([onward is False for onward in onwards], np.bool_)
    value = np.where(pdi, DL_PDI_OPERATIONAL, 0) | DL_PORT0 | DL_PORTS_2_3_CLOSED
    value |= np.where(link, DL_PORT1_LINK, 0) | np.where(closed, DL_PORT1_CLOSED, 0)
    old = memory[rows, REG_DL_STATUS].astype(np.int64)
    old |= memory[rows, REG_DL_STATUS + 1].astype(np.int64) << 8
    differs = value != old
    changed, new = rows[differs], value[differs]
    memory[changed, REG_DL_STATUS] = new & 0xFF
    memory[changed, REG_DL_STATUS + 1] = new >> 8
    memory[changed, REG_ECAT_EVENT] |= EVENT_DL_STATUS


def _masked(
    memory: npt.NDArray[np.uint8],
    rows: _Rows | slice,
    lo: int,
    hi: int,
    data: npt.NDArray[np.uint8],
    mask: npt.NDArray[np.uint8],
) -> None:
    """Bytes [lo, hi) of ``rows`` from ``data`` (one row, or one per row) where ``mask`` has
    bits: read-only and reserved bits keep their value (datasheet II, column ECAT)."""
    if hi - lo >= _WIDE and (mask[1:-1] == 0xFF).all():  # whole bytes: only the ends masked
        memory[rows, lo + 1 : hi - 1] = data[..., 1:-1]
        for k in (0, hi - lo - 1):
            if mask[k]:
                old_k = memory[rows, lo + k]
                memory[rows, lo + k] = (old_k & ~mask[k]) | (data[..., k] & mask[k])
        return
    old = memory[rows, lo:hi]
    memory[rows, lo:hi] = (old & ~mask) | (data & mask)


def _special(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    lo: int,
    hi: int,
    data: npt.NDArray[np.uint8],
    enabled: npt.NDArray[np.uint8] | None,
    masks: npt.NDArray[np.uint8],
    flags: list[bool],
    eeprom: npt.NDArray[np.bool_],
) -> None:
    """:meth:`EscDevice._special_write` at every row, of ``data`` (one row, or one per row):
    error counters cleared (II 2.6), the EEPROM interface where ECAT owns it (I 11.2.2),
    SyncManager bytes 0-4 kept where the SyncManager was enabled (II 2.14.1), DC receive times
    and system time compare (:func:`compare_together`)."""
    if lo < REG_PU_ERRORS:  # one write clears all RX error counters
        memory[rows, REG_ERROR_COUNTERS:REG_PU_ERRORS] = 0
        return
    if lo < 0x0314 or lo in (0x0442, 0x0443):
        memory[rows, lo:hi] = 0
        return
    if lo < REG_EEPROM_CONTROL:  # 0x0500 may hand the interface to ECAT
        if lo == REG_EEPROM_CONFIG:
            force = np.broadcast_to((data[..., 0] & 0x02) != 0, rows.shape)
            memory[rows[force], REG_EEPROM_PDI] &= 0xFE  # force ECAT access
        _masked(memory, rows, lo, hi, data, masks[lo:hi])
        return
    if lo < 0x0510:
        owner = ((memory[rows, REG_EEPROM_CONFIG] | memory[rows, REG_EEPROM_PDI]) & 0x01) == 0
        if owner.any():
            mine = data[owner] if data.ndim > 1 else data
            _masked(memory, rows[owner], lo, hi, mine, masks[lo:hi])
            if lo < REG_EEPROM_CONTROL + 2:
                eeprom |= owner
        return
    if lo >= REG_DC_RECEIVE:  # receive time latch, system time compare
        compare_together(
            [dev.dc for dev in devices], memory, rows, lo, data if data.ndim > 1 else data.tobytes()
        )
        return
    assert enabled is not None
    # configuration bytes 0-4 of a SyncManager enabled before the frame keep their value
    at = np.arange(lo - REG_SM, hi - REG_SM)
    keep = (enabled[:, at // SM_BYTES] & 0x01).astype(np.bool_) & (at % SM_BYTES < 5)
    old = memory[rows, lo:hi]
    new = np.where(keep, old, data)
    mask = masks[lo:hi]
    memory[rows, lo:hi] = (old & ~mask) | (new & mask)  # _masked, the bytes before at hand
    flags[4] = True


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
    ``devices`` (the ESCs of ``rows``; :meth:`EscDevice.shadow_writes`), alike at every ESC
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
    at = _every(np.asarray(rows, np.intp))
    arrived = np.frombuffer(buf, np.uint8, n, off)[None, :]
    if reads:  # the frame leaves with the last ESC's reads
        out = arrived.copy()
        _read_rows(memory, slice(rows[-1], rows[-1] + 1), reads, out)
    read = [(b, b + c) if bytewise else (e, e + f) for bytewise, _, b, c, _, e, f in reads]
    met = [  # per write (and shadow write), whether a read replaces some of its frame bytes
        any(x < hi and y > lo for x, y in read)
        for lo, hi in (
            (b, b + c) if bytewise else (e, e + f)
            for bytewise, _, b, c, _, e, f in (*writes, *shadow)
        )
    ]
    data_in = arrived  # the frame bytes no ESC reads arrive alike at every ESC: one row
    if any(met):  # per ESC, the data as it arrived there, from the memory before any write
        left = np.repeat(arrived, m, axis=0)  # the data as each ESC leaves it
        _read_rows(memory, at, reads, left)
        data_in = np.concatenate((arrived, left[:-1]))
    if shadow:  # the registers as committed: no write of the datagram reaches them
        _shadow_rows(memory, at, shadow, met[len(writes) :], arrived, data_in, devices)
    for (bytewise, a, b, c, d, e, f), varies in zip(writes, met[: len(writes)], strict=True):
        src = data_in if varies else arrived
        if bytewise:  # physical a, frame offset b, c bytes
            memory[at, a : a + c] = src[:, b : b + c]
        else:  # physical bytes [a, a + b) under mask d, shift c, frame bytes [e, e + f)
            _masked(memory, at, a, a + b, _shifted(src[:, e : e + f], -c, b), _mask(d, b))
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
    """:meth:`EscDevice.shadow_writes` of the write parts ``shadow`` at each of ``devices``
    (whose memory is ``memory[at]``), put among its shadow writes
    (:meth:`EscDevice.write_shadow`): from the data as it arrived, ``arrived`` where no read
    replaces their frame bytes (``varies``), else ``data_in`` (a row per ESC); one
    (address, bytes) for all where the bytes are alike."""
    for (bytewise, a, b, c, d, e, f), per_row in zip(shadow, varies, strict=True):
        src = data_in if per_row else arrived
        if bytewise:  # physical a, frame offset b, c bytes
            written = src[:, b : b + min(c, REGISTER_END - a)]
        else:  # physical bytes [a, a + b) under mask d, shift c, frame bytes [e, e + f)
            k = min(b, REGISTER_END - a)  # the register bytes: the shift's low k bytes alone
            mask = _mask(d, b)[:k]
            new = _shifted(src[:, e : e + f], -c, k)
            written = (memory[at, a : a + k] & ~mask) | (new & mask)
        resets = a <= REG_RESET_ECAT < a + written.shape[1]  # each ESC counts its reset byte
        if len(written) == 1 or (written == written[0]).all():
            entry = (a, written[0].tobytes())
            if resets:
                for dev in devices:
                    dev.write_shadow((entry,))
            else:  # what write_shadow does there: the entry among each ESC's shadow writes
                for dev in devices:
                    dev.pending.append(entry)
        elif resets:
            for dev, row in zip(devices, written, strict=True):
                dev.write_shadow(((a, row.tobytes()),))
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
    for bytewise, a, b, c, d, e, f in reads:
        if bytewise:  # physical a, frame offset b, c bytes
            left[:, b : b + c] = memory[rows, a : a + c]
        else:  # physical bytes [a, a + b), shift c, mask d, frame bytes [e, e + f)
            _masked(
                left, slice(None), e, e + f, _shifted(memory[rows, a : a + b], c, f), _mask(d, f)
            )


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


def lrd_last_readers(
    devices: Sequence[EscDevice],
    accesses: Sequence[PlainAccess],
    buf: bytearray,
    off: int,
    n: int,
) -> int:
    """An LRD (data ``buf[off:off+n]``, in place) through consecutive ESCs ``devices``, each
    of which maps it onto plain memory by its own plan (:meth:`EscDevice.plain_access`), as
    each in turn would do it: the working counter's increment.

    An ESC's reads replace their bits of the frame and nothing else happens, so a bit leaves
    with the value of the last ESC that reads it. The ESCs are worked from the last back, each
    reading only the bits no later ESC reads: once every bit is read, the ESCs before count
    in the working counter and read nothing, whatever their FMMUs ask for. The work per part
    is bounded by the frame bytes it maps (the bits still unread are kept per frame byte).
    """
    return last_readers(devices, [access[2] for access in accesses], buf, off, n)


def last_readers(
    devices: Sequence[EscDevice],
    plans: Sequence[LogicalPlan],
    buf: bytearray,
    off: int,
    n: int,
    buffers: Mapping[int, tuple[int, bytes]] | None = None,
) -> int:
    """:func:`lrd_last_readers` of the ESCs' plans cut (:attr:`emulator.esc.mapping.Access.cut`);
    ``buffers``, by index into ``devices``: the whole buffer an ESC's first FMMU read (its frame
    offset and bytes, :meth:`EscDevice.read_first_buffer`), one more part of its reads, apart
    from those of its plan (the first FMMU claimed those bytes from the others)."""
    unread = (1 << 8 * n) - 1  # the frame bits no later ESC reads (bit 8 i + k: byte i, bit k)
    wkc = 0
    last = len(devices) - 1
    for k, (dev, plan) in enumerate(zip(reversed(devices), reversed(plans), strict=True)):
        reads = plan[0]  # the plan with the holes cut: each part reads a byte
        read = buffers.get(last - k) if buffers else None
        if not reads and read is None:
            continue
        wkc += 1
        if not unread:  # nothing left to read: it only counts
            continue
        if read is not None:
            at, data = read
            new = (unread >> 8 * at) & ((1 << 8 * len(data)) - 1)  # what no later ESC reads
            if new:
                _merge(buf, off + at, len(data), new, int.from_bytes(data, "little"))
                unread ^= new << 8 * at
        mem = dev.mem
        for bytewise, a, b, c, d, e, f in reads:
            if bytewise:  # physical a, frame offset b, c bytes
                at, width, mask = b, c, (1 << 8 * c) - 1
            else:  # physical bytes [a, a + b), shift c, mask d of frame bytes [e, e + f)
                at, width, mask = e, f, d
            new = unread >> 8 * at & mask  # what this part reads that no later ESC does
            if not new:
                continue
            if bytewise:
                value = int.from_bytes(mem[a : a + c], "little")
            else:
                value = int.from_bytes(mem[a : a + b], "little")
                value = value >> c if c >= 0 else value << -c
            _merge(buf, off + at, width, new, value)
            unread ^= new << 8 * at
    return wkc


def _merge(buf: bytearray, at: int, width: int, bits: int, value: int) -> None:
    """The ``width`` bytes of ``buf`` at ``at``, as a little-endian integer, take ``value``'s
    bits where ``bits`` has them."""
    frame = int.from_bytes(buf[at : at + width], "little")
    buf[at : at + width] = ((frame & ~bits) | (value & bits)).to_bytes(width, "little")
