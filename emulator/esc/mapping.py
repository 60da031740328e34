"""How an ESC maps its memory: the FMMU and SyncManager register tables decoded, and logical
accesses planned through the FMMUs (datasheet I 7, 8; II 2.13, 2.14).

Functions of register bytes only: a table is decoded once per distinct bytes, a plan worked out
once per access and the FMMUs it meets, in caches of bounded size (:func:`remember`) that belong
to one chain (:class:`Caches`) and are shared by its ESCs configured alike; two chains never see
each other's. :class:`emulator.esc.device.EscDevice` carries the plans out.
"""

from __future__ import annotations

import itertools
import struct
from collections.abc import Callable, Sequence
from typing import Any, Final, NamedTuple, Protocol, TypeVar

from emulator.esc.commands import LRD, LWR
from emulator.esc.registers import (
    ADDRESS_SPACE,
    REG_ECAT_EVENT,
    REG_SM,
    REGISTER_END,
    SM_BYTES,
    cleared_events,
    reads_dc,
)

__all__ = [
    "FMMU_ENTRY",
    "SM_ENTRY",
    "Access",
    "Caches",
    "Fmmu",
    "FmmuTable",
    "Holes",
    "LogicalPlan",
    "Mailboxes",
    "PartHoles",
    "PlainAccess",
    "Plans",
    "RowAccess",
    "SmChange",
    "SmEntry",
    "SmFound",
    "SmTable",
    "WritesInert",
    "byte_op",
    "cut",
    "decode_entries",
    "decode_fmmus",
    "decode_sms",
    "esc_row_access",
    "fmmu_table",
    "forget",
    "outside",
    "plan_logical",
    "plans_key",
    "remember",
    "shared_access",
    "sm_change",
    "sm_table",
    "table_access",
    "unclaimed",
    "without",
]


SM_ENTRY: Final = struct.Struct("<HHBBBB")  # one SyncManager's registers (datasheet II 2.14)
FMMU_ENTRY: Final = struct.Struct("<IHBBHBBB3x")  # one FMMU's registers (datasheet II 2.13)

DECODE_CACHE_ENTRIES: Final = 4096  # distinct FMMU/SM tables remembered (memory bound)
PLAN_CACHE_ENTRIES: Final = 1 << 12  # distinct accesses remembered (memory bound)


class LogicalOp(NamedTuple):
    """A part of a logical access's plan (:func:`plan_logical`): physical bytes [phys, phys +
    size) and frame bytes [at, at + width) of the datagram's data that one FMMU maps onto each
    other. Byte-wise (:func:`byte_op`): the same bytes, ``width`` = ``size``, ``shift`` and
    ``mask`` 0. Bit-wise: ``shift`` is where a frame bit lies in the physical bytes minus where
    it lies in the frame bytes, ``mask`` the mapped bits: of the frame bytes (a read) or of the
    physical bytes (a write)."""

    bytewise: bool
    phys: int
    size: int
    shift: int
    mask: int
    at: int
    width: int


LogicalPlan = tuple[tuple[LogicalOp, ...], tuple[LogicalOp, ...]]  # reads, writes

# a NamedTuple made by calling its class runs the class's __new__ as Python, compiled too (some
# 3,000 instructions); tuple.__new__ of the class and the fields makes the same object natively.
# Each record has one typed function that makes it so (:func:`_op`, :func:`_part_holes`,
# :func:`_plain_access`, :func:`_row_access`): mypy checks the fields there, and a test that
# each gives what the class gives of the same fields
_new: Final = tuple.__new__


def _op(
    bytewise: bool, phys: int, size: int, shift: int, mask: int, at: int, width: int
) -> LogicalOp:
    """``LogicalOp(bytewise, phys, size, shift, mask, at, width)``, made natively."""
    return _new(LogicalOp, (bytewise, phys, size, shift, mask, at, width))


def byte_op(phys: int, at: int, n: int) -> LogicalOp:
    """The byte-wise part that maps physical bytes [phys, phys + n) onto frame bytes
    [at, at + n)."""
    return _op(True, phys, n, 0, 0, at, n)


# the accesses through an FMMU table by command, logical address and length, in one int
# (:func:`plans_key`; :func:`table_access`)
Plans = dict[int, "Access"]


def plans_key(cmd: int, lad: int, n: int) -> int:
    """The key of an access (``cmd``, ``n`` bytes at the 32-bit ``lad``) in :data:`Plans`: an
    int, which hashes and compares faster than a tuple and is nothing the garbage collector
    walks (every ESC a logical datagram reaches looks its access up, and hostile ones are new
    at nearly every ESC)."""
    return (n << 32 | lad) << 8 | cmd


class Fmmu(NamedTuple):
    """An active FMMU as decoded (datasheet II 2.13, :func:`decode_entries`), clipped to the
    logical and the physical address spaces."""

    log_start: int  # logical start address
    log_end: int  # logical end (exclusive), clipped
    phys: int  # physical start address
    start_bit: int  # logical start bit
    stop_bit: int  # logical stop bit
    phys_bit: int  # physical start bit
    reads: int  # type bit 0: read (1) or not (0)
    writes: int  # type bit 1: write (1) or not (0)
    bytewise: bool  # start bit 0, stop bit 7, physical bit 0: whole bytes
    bits: int  # bits left in the address space from the physical start


class FmmuTable:
    """Active FMMUs in register order, the logical span they map, and the plans of logical
    accesses through them (shared by every ESC whose FMMU registers hold the same bytes); for a
    table decoded as FMMU 0 and the others (:func:`decode_fmmus`), those two parts (``parts``,
    each a table of its own). A class, not a NamedTuple: compiled (mypyc), it is made
    as a native object, where a NamedTuple runs its ``__new__`` as Python (a frame that changes
    the FMMUs of every ESC makes one at each)."""

    __slots__ = ("fmmus", "parts", "plans", "span")

    def __init__(
        self,
        fmmus: tuple[Fmmu, ...],
        span: tuple[int, int],
        parts: tuple[FmmuTable, FmmuTable] | None = None,
    ) -> None:
        self.fmmus = fmmus
        self.span = span
        self.plans: Plans = {}
        self.parts = parts


class SmEntry(NamedTuple):
    """A SyncManager that controls memory, as decoded (:func:`decode_sms`)."""

    number: int  # the SyncManager: 0x0800 + 8 number
    start: int
    length: int  # clipped to the address space
    control: int  # register 0x0804 + 8 index
    locked: int  # deactivated by the PDI (0x0807 bit 0): 1, or the change's bool (sm_change)


SmTable = tuple[SmEntry, ...]
# mailboxes an access meets where ECAT accesses them: (SyncManager index, side 0 read / 1 write)
# (esc_row_access)
Mailboxes = tuple[tuple[int, int], ...]
_K = TypeVar("_K")
_V = TypeVar("_V")


class SmFound(NamedTuple):
    """A decoded SyncManager table with what follows from it alone (:func:`sm_table`)."""

    entries: SmTable
    by_start: tuple[int, ...]  # the order of the entries by start (PDI-locked last)
    idle: tuple[int, ...]  # the status registers (0x0805 + 8 y) of those without a buffer


class SmChange(NamedTuple):
    """What a change of the decoded SyncManager table does (:func:`sm_change`)."""

    no_buffer: tuple[int, ...]  # the status registers set to "no buffer"
    gone: tuple[int, ...]  # the indices of the SyncManagers without a buffer
    fresh: SmTable  # those that start anew (locked as a bool)
    kept: SmTable  # those that keep their state (locked as a bool)
    by_start: tuple[int, ...]  # the indices of those with a buffer, by start (PDI-locked last)


class Caches:
    """What one chain's ESCs decode and plan once and share (issue 39: no process-wide state):
    each dict bounded by :func:`remember`. A chain makes one for its ESCs
    (:meth:`emulator.esc.device.EscDevice._use_caches`); an ESC on its own has its own."""

    __slots__ = (
        "access",
        "as_new",
        "events",
        "fmmu",
        "fmmu_parts",
        "joined",
        "layouts",
        "links",
        "parts",
        "sm",
        "sm_change",
        "write_plans",
    )

    def __init__(self) -> None:
        # FMMU register bytes decoded, with the plans of accesses through them (fmmu_table)
        self.fmmu: dict[bytes, FmmuTable] = {}
        # FMMU 0's registers and the others', decoded, with the plans of accesses through them
        # (decode_fmmus, table_access)
        self.fmmu_parts: dict[bytes, FmmuTable] = {}
        # logical accesses by the FMMUs they meet (shared_access)
        self.access: dict[tuple[object, ...], Access] = {}
        # the accesses of an access's first FMMU and of the FMMUs after it, by the FMMUs they
        # meet (Access.rows)
        self.parts: dict[tuple[object, ...], Access] = {}
        # accesses through FMMU 0 and other FMMUs, by the accesses through each part
        # (table_access)
        self.joined: dict[tuple[object, ...], Access] = {}
        self.sm: dict[bytes, SmFound] = {}  # decoded SyncManager tables (sm_table)
        # how many times an ESC's FMMUs or SyncManagers changed: what the chain planned from
        # them before holds while this stays (emulator.esc.chain.EcatChain's image reads)
        self.layouts = 0
        # how many times an ESC's event request (EscDevice.irq) changed, and its forwarding or
        # source MAC marking were worked out (DL status): what the chain ORed or found holds
        # while these stay
        self.events = 0
        self.links = 0
        # changes of the decoded SyncManager table (sm_change)
        self.sm_change: dict[tuple[SmTable, bytes | None, SmFound], SmChange] = {}
        # per decoded SyncManager table and SyncManager count, its SyncManagers as new, by
        # index (None where none): shared by the ESCs that make them until one changes one
        # (emulator.esc.device.EscDevice; the objects are its own)
        self.as_new: dict[tuple[SmTable, int], list[Any]] = {}
        # how register writes are cut, per ESC configuration
        # (emulator.esc.write_plans.WritePlans)
        self.write_plans: dict[object, Any] = {}


def forget() -> None:
    """Nothing: kept for scripts written when the caches were the process's. They belong to
    each chain now (:class:`Caches`), so a chain made anew starts with none."""


def remember(cache: dict[_K, _V], key: _K, value: _V, limit: int = DECODE_CACHE_ENTRIES) -> _V:
    """Store ``value`` under ``key``; when the cache is full its oldest 1/64 goes (bounded
    memory; emptying a full table cache at once had taken 13 ms inside one frame)."""
    if len(cache) >= limit:
        for old in list(itertools.islice(cache, max(1, limit // 64))):
            del cache[old]
    cache[key] = value
    return value


def decode_fmmus(caches: Caches, table: bytes) -> tuple[tuple[Fmmu, ...], tuple[int, int]]:
    """The active FMMUs of the registers 0x0600+ (datasheet II 2.13) in register order, clipped,
    and the logical span they map (:func:`decode_entries`): FMMU 0 and the others decoded
    apart, each once per distinct bytes (:attr:`Caches.fmmu_parts`), since a broadcast to the
    FMMUs of a configured line leaves every ESC's FMMUs differing in FMMU 0 alone (its own
    logical bytes)."""
    parts = _fmmu_parts(caches, table)
    return decode_entries(table) if parts is None else _joined(parts[0], parts[1])


def _fmmu_parts(caches: Caches, table: bytes) -> tuple[FmmuTable, FmmuTable] | None:
    """FMMU 0 and the others of the registers ``table`` decoded, each once per distinct bytes
    (:attr:`Caches.fmmu_parts`); None for a table of one FMMU."""
    size = FMMU_ENTRY.size
    if len(table) <= size:
        return None
    parts = caches.fmmu_parts
    head, rest = table[:size], table[size:]
    first = parts.get(head)
    if first is None:
        fmmus, span = decode_entries(head)
        first = remember(parts, head, FmmuTable(fmmus, span))
    others = parts.get(rest)
    if others is None:
        fmmus, span = decode_entries(rest)
        others = remember(parts, rest, FmmuTable(fmmus, span))
    return first, others


def _joined(first: FmmuTable, others: FmmuTable) -> tuple[tuple[Fmmu, ...], tuple[int, int]]:
    """The FMMUs and span of a table from those of its two parts (:func:`_fmmu_parts`)."""
    if not first.fmmus:
        return others.fmmus, others.span
    if not others.fmmus:
        return first.fmmus, first.span
    span = (min(first.span[0], others.span[0]), max(first.span[1], others.span[1]))
    return first.fmmus + others.fmmus, span


def decode_entries(table: bytes) -> tuple[tuple[Fmmu, ...], tuple[int, int]]:
    """The active FMMUs of the registers 0x0600+ (datasheet II 2.13), or of some of them, in
    register order, clipped, and the logical span they map.

    Every value a frame can write is legal: the logical side ends at 0xFFFFFFFF, and the
    physical side ends with the 64 KiB address space (datasheet I 1.1): logical bytes (or
    bits) whose physical counterpart would lie beyond 0xFFFF are not mapped, so they are
    neither read nor written and do not count (:class:`Fmmu`).
    """
    fmmus: list[Fmmu] = []
    for log, length, sbit, ebit, phys, pbit, kind, act in FMMU_ENTRY.iter_unpack(table):
        if not (act & 0x01 and length and kind & 0x03):
            continue
        log_end = min(log + length, 1 << 32)
        bytewise = sbit == 0 and ebit == 7 and pbit == 0
        if bytewise:
            log_end = min(log_end, log + ADDRESS_SPACE - phys)
        phys_bits = ADDRESS_SPACE * 8 - (phys * 8 + pbit)  # bits left in the address space
        fmmus.append(  # (log_end > log: log < 2^32, length >= 1, phys < 64 KiB)
            Fmmu(log, log_end, phys, sbit, ebit, pbit, kind & 1, kind >> 1 & 1, bytewise, phys_bits)
        )
    span = (min(f.log_start for f in fmmus), max(f.log_end for f in fmmus)) if fmmus else (0, 0)
    return tuple(fmmus), span  # span: logical bytes any FMMU maps (the chain skips the others)


def decode_sms(table: bytes) -> SmTable:
    """(index, start, length clipped to 64 KiB, control, PDI-locked) of the SyncManagers that
    control memory: enabled, length >= 2 (datasheet I 8.5, II 2.14)."""
    out = []
    for y, (start, length, control, _, activate, pdi) in enumerate(SM_ENTRY.iter_unpack(table)):
        length = min(length, ADDRESS_SPACE - start)  # no memory beyond 0xFFFF (I 1.1)
        if activate & 0x01 and length >= 2:
            out.append(SmEntry(y, start, length, control, pdi & 0x01))
    return tuple(out)


def fmmu_table(caches: Caches, table: bytes) -> FmmuTable:
    """The FMMU register bytes ``table`` (0x0600 on, 16 bytes an FMMU) decoded
    (:func:`decode_fmmus`), with empty :data:`Plans` for the accesses through them, and the
    table's two parts: once per distinct bytes (:attr:`Caches.fmmu`), so that ESCs
    whose FMMUs hold the same bytes share it."""
    found = caches.fmmu.get(table)
    if found is not None:
        return found
    parts = _fmmu_parts(caches, table)
    fmmus, span = decode_entries(table) if parts is None else _joined(parts[0], parts[1])
    return remember(caches.fmmu, table, FmmuTable(fmmus, span, parts=parts))


def sm_table(caches: Caches, table: bytes) -> SmFound:
    """The SyncManager register bytes ``table`` (0x0800 on, 8 bytes a SyncManager) decoded
    (:func:`decode_sms`), with the order of its entries and the status registers of the
    SyncManagers without a buffer: once per distinct bytes (:attr:`Caches.sm`)."""
    found = caches.sm.get(table)
    if found is None:
        entries = decode_sms(table)
        by_start = sorted(
            range(len(entries)), key=lambda i: (entries[i].start, entries[i].locked != 0)
        )
        enabled = {e.number for e in entries}
        idle = tuple(
            REG_SM + SM_BYTES * z + 5 for z in range(len(table) // SM_BYTES) if z not in enabled
        )
        found = remember(caches.sm, table, SmFound(entries, tuple(by_start), idle))
    return found


def sm_change(
    caches: Caches, before: SmTable, enabled_before: bytes | None, found: SmFound
) -> SmChange:
    """What an ESC's SyncManagers go through when their decoded table turns from ``before`` into
    ``found`` (:func:`sm_table`), with ``enabled_before`` the activate bytes before the frame
    (None: not written by a frame): one that was not controlling memory, was disabled before the
    frame (toggled) or moved or changed its length starts anew, without a buffer; the others
    keep their state (datasheet I 8.1, II 2.14.1); those left out have no buffer. It follows
    from the tables alone, so it is worked out once (:attr:`Caches.sm_change`) and shared by
    every ESC that makes the same change."""
    key = (before, enabled_before, found)
    change = caches.sm_change.get(key)
    if change is not None:
        return change
    after, order, idle = found
    was = {e.number: e for e in before}
    fresh, kept = [], []
    for y, start, length, control, pdi_locked in after:
        entry = SmEntry(y, start, length, control, pdi_locked != 0)
        old = was.get(y)
        if (
            old is None
            or (enabled_before is not None and not enabled_before[y] & 1)
            or old.start != start
            or old.length != length
        ):
            fresh.append(entry)
        else:
            kept.append(entry)
    no_buffer = idle + tuple(REG_SM + SM_BYTES * e.number + 5 for e in fresh)
    gone = tuple((st - REG_SM) // SM_BYTES for st in idle)
    by_start = tuple(after[i].number for i in order)
    change = SmChange(no_buffer, gone, tuple(fresh), tuple(kept), by_start)
    return remember(caches.sm_change, key, change)


def plan_logical(fmmus: tuple[Fmmu, ...], cmd: int, lad: int, n: int) -> LogicalPlan:
    """How a logical access of ``n`` bytes at ``lad`` reads and writes through ``fmmus``
    (datasheet I 7): the parts each FMMU maps, in register order, the lower-numbered FMMU
    winning a logical byte claimed twice (reads and writes claim separately); a part the
    64 KiB address space clips away is not mapped. A bit-wise part's physical bytes hold the
    mapped bits, its frame bytes those they lie in (:class:`LogicalOp`): its work is bounded by
    the mapped bytes, not by the datagram's length."""
    lo, hi = lad, lad + n
    hit = [f for f in fmmus if not (f.log_end <= lo or f.log_start >= hi)]
    reads = [f for f in hit if f.reads and cmd != LWR]
    writes = [f for f in hit if f.writes and cmd != LRD]
    plan: list[list[LogicalOp]] = [[], []]
    for ops, side, write in ((plan[0], reads, False), (plan[1], writes, True)):
        claimed: list[tuple[int, int]] | None = [] if len(side) > 1 else None
        for f in side:
            log_start, phys = f.log_start, f.phys
            for a, b in claim(claimed, max(lad, log_start), min(lad + n, f.log_end)):
                if f.bytewise:
                    ops.append(byte_op(phys + (a - log_start), a - lad, b - a))
                    continue
                # bit-wise: logical bit b maps to physical bit p0 + (b - b0), as whole integers
                b0, b1, p0 = bit_span(f, a, b)
                if b0 > b1:
                    continue
                first, last = p0 // 8, (p0 + b1 - b0) // 8
                at, end = (b0 - lad * 8) // 8, (b1 - lad * 8) // 8  # the frame bytes
                shift = (p0 - first * 8) - (b0 - lad * 8 - at * 8)  # physical bit - frame bit
                bits = (1 << (b1 - b0 + 1)) - 1
                mask = bits << (p0 - first * 8) if write else bits << (b0 - lad * 8 - at * 8)
                ops.append(_op(False, first, last - first + 1, shift, mask, at, end - at + 1))
    return tuple(plan[0]), tuple(plan[1])


class PartHoles(NamedTuple):
    """The bytes of a plan's part where it does nothing (:func:`esc_row_access`)."""

    side: int  # 0 reads, 1 writes
    part: int  # the part's place among them
    holes: tuple[tuple[int, int], ...]  # [start, end) in physical bytes


Holes = tuple[PartHoles, ...]  # in plan order


def _part_holes(side: int, part: int, holes: tuple[tuple[int, int], ...]) -> PartHoles:
    """``PartHoles(side, part, holes)``, made natively (:data:`_new`)."""
    return _new(PartHoles, (side, part, holes))


class PlainAccess(NamedTuple):
    """A logical access that is all plain memory (:func:`esc_row_access`)."""

    plan: LogicalPlan
    holes: Holes  # where it does nothing
    cut: LogicalPlan  # the plan without the holes (:func:`cut`)


def _plain_access(plan: LogicalPlan, holes: Holes, cut: LogicalPlan) -> PlainAccess:
    """``PlainAccess(plan, holes, cut)``, made natively (:data:`_new`)."""
    return _new(PlainAccess, (plan, holes, cut))


class WritesInert(Protocol):
    """What :class:`Access` asks of an ESC's register write plans
    (:class:`emulator.esc.write_plans.WritePlans`)."""

    def inert(self, addr: int, n: int) -> bool: ...


class Access:
    """A logical access (``cmd``, ``n`` bytes at ``lad``) by the FMMUs it meets, ``hit`` (active
    FMMUs in register order): its plan (:attr:`plan`, worked out when first asked), and what the
    chain may do over the rows (:meth:`rows`) with the SyncManager areas, memory top and
    register write plans last asked: ``cut``, the plan without the bytes where it does nothing
    (None: not plain, :func:`esc_row_access`), ``events``, those its register reads clear,
    ``mailboxes``, those that must be idle at an ESC for the cut to hold there, ``dc``, the
    registers each ESC brings up to the frame's time first, ``shadow``, the write parts whose
    register bytes each ESC puts among its shadow writes (:func:`esc_row_access`)."""

    __slots__ = (
        "_caches",
        "_first",
        "_others",
        "_plan",
        "_registers",
        "areas",
        "cmd",
        "cut",
        "dc",
        "events",
        "hit",
        "lad",
        "mailboxes",
        "n",
        "shadow",
        "top",
        "writes",
    )

    def __init__(self, caches: Caches, hit: tuple[Fmmu, ...], cmd: int, lad: int, n: int) -> None:
        self._caches = caches  # the chain's, where its parts are kept
        self.hit, self.cmd, self.lad, self.n = hit, cmd, lad, n
        self._plan: LogicalPlan | None = None
        self._registers: tuple[bool, bool] | None = None
        self._first: Access | None = None  # the first FMMU's access (Caches.parts)
        self._others: Access | None = None  # the others' (Caches.parts)
        self.areas: SmTable | None = None
        self.top = 0
        self.writes: WritesInert | None = None  # the register write plans (inert writes)
        self.cut: LogicalPlan | None = None
        self.events = 0
        self.mailboxes: Mailboxes = ()
        self.dc: tuple[tuple[int, int], ...] = ()
        self.shadow: tuple[LogicalOp, ...] = ()

    @staticmethod
    def joined(first: Access, others: Access) -> Access:
        """The access through FMMU 0 and others that ``first`` and ``others`` (accesses alike
        through each, meeting some) are: its :meth:`rows` work from theirs (:meth:`_apart`).
        (Static, made as Access: compiled, a class method's ``cls(...)`` is a generic call.)"""
        found = Access(first._caches, first.hit + others.hit, first.cmd, first.lad, first.n)
        found._first, found._others = first, others
        return found

    @property
    def plan(self) -> LogicalPlan:
        """:func:`plan_logical` of the access."""
        if self._plan is None:
            self._plan = plan_logical(self.hit, self.cmd, self.lad, self.n)
        return self._plan

    @property
    def registers(self) -> tuple[bool, bool]:
        """Whether the plan reads, and whether it writes, registers (below 0x0F80)."""
        if self._registers is None:
            reads, writes = (any(op.phys < REGISTER_END for op in ops) for ops in self.plan)
            self._registers = reads, writes
        return self._registers

    def rows(self, areas: SmTable, top: int, writes: WritesInert) -> None:
        """Work out :attr:`cut`, :attr:`events`, :attr:`mailboxes`, :attr:`dc` and
        :attr:`shadow` for SyncManager ``areas``, memory ``top`` and register write plans
        ``writes`` (:func:`esc_row_access`), unless they were the last asked.

        When the access meets several FMMUs, the first FMMU's part and the others' (accesses of
        their own, :attr:`Caches.parts`, shared by every access they are part of) are worked out
        apart: after a broadcast to the FMMUs of ESCs that each map their own logical bytes
        with FMMU 0, every ESC's FMMUs differ in the first alone, and the others' cut is worked
        out once. The first FMMU claims its logical bytes from the others (datasheet I 7), so
        the others' cut loses the bits of those frame bytes (:func:`unclaimed`); which bytes
        are plain follows byte by byte, and what the others' parts do in registers (read
        without side effect) too, so the cut is that of the whole plan (:meth:`_apart`)."""
        if self.areas is areas and self.top == top and self.writes is writes:
            return
        self.areas, self.top, self.writes = areas, top, writes
        if len(self.hit) > 1 and self._apart(areas, top, writes):
            return
        found = esc_row_access(self.plan, areas, top, writes.inert)
        if found is None:
            self.cut, self.events, self.mailboxes = None, 0, ()
            self.dc, self.shadow = (), ()
            return
        access, self.events, self.mailboxes, self.dc, self.shadow = found
        self.cut = access.cut

    def _apart(self, areas: SmTable, top: int, writes: WritesInert) -> bool:
        """:meth:`rows` from the first FMMU's part and the others' cut, when another access met
        the others before (:attr:`Caches.parts`; else each ESC would work out the others as
        well as the whole plan), and the others are plain, clear no event, read no DC register
        and write no register to the shadow (the first's part is the whole plan's, theirs may
        be narrower, which would refresh or write other registers), read no register
        after a read of the first that clears one, and write (inert) registers only in parts
        whose frame bytes the first does not claim (such a write counts in the working counter
        if the claims leave any of it, though it writes no byte); False leaves it to the whole
        plan."""
        cmd, lad, n = self.cmd, self.lad, self.n
        others = self._others
        if others is None:
            key = (self.hit[1:], cmd, lad, n)
            parts = self._caches.parts
            others = parts.get(key)
            if others is None:  # met for the first time: shared by no other access (yet)
                found = Access(self._caches, self.hit[1:], cmd, lad, n)
                remember(parts, key, found, PLAN_CACHE_ENTRIES)
                return False
            self._others = others
        reads_registers, writes_registers = others.registers
        others.rows(areas, top, writes)
        if others.cut is None or others.events or others.dc or others.shadow:
            return False
        first = self._first
        if first is None:  # an ESC's own FMMU 0 outlives the others' changes: remembered
            key = (self.hit[:1], cmd, lad, n)
            parts = self._caches.parts
            first = parts.get(key)
            if first is None:
                found = Access(self._caches, self.hit[:1], cmd, lad, n)
                first = remember(parts, key, found, PLAN_CACHE_ENTRIES)
            self._first = first
        first.rows(areas, top, writes)
        if first.cut is None or (first.events and reads_registers):
            return False  # (a read of the event request after the first cleared an event)
        return self._claimed(
            first.cut,
            first.shadow,
            (first.events, first.dc, _merged(first.mailboxes, others.mailboxes)),
            others.cut,
            others.plan[1] if writes_registers else (),
        )

    def _claimed(
        self,
        first_cut: LogicalPlan,
        shadow: tuple[LogicalOp, ...],
        effects: tuple[int, tuple[tuple[int, int], ...], Mailboxes],
        others_cut: LogicalPlan,
        register_writes: tuple[LogicalOp, ...],
    ) -> bool:
        """The cut of :meth:`_apart` from the first FMMU's part's cut and shadow, its events,
        DC registers and the mailboxes of both (``effects``), and the others' cut, the frame
        bytes the first claims taken from the others' (:func:`unclaimed`); False where the
        others' write parts of (inert) registers ``register_writes`` meet those bytes."""
        cmd, lad, n = self.cmd, self.lad, self.n
        f = self.hit[0]
        lo, hi = (
            max(lad, f.log_start) - lad,
            min(lad + n, f.log_end) - lad,
        )  # the frame bytes it claims
        reads, writes_ = others_cut
        if f.reads and cmd != LWR:
            reads = unclaimed(reads, lo, hi, False)
        if f.writes and cmd != LRD:
            if any(
                op.phys < REGISTER_END and op.at < hi and op.at + op.width > lo
                for op in register_writes
            ):
                return False  # a write of (inert) registers counts if the claims leave any of it
            writes_ = unclaimed(writes_, lo, hi, True)
        self.cut = (first_cut[0] + reads, first_cut[1] + writes_)
        # the others' parts, fewer bytes than theirs, clear no event
        self.events, self.dc, self.mailboxes = effects
        self.shadow = shadow
        return True


def _merged(first: Mailboxes, others: Mailboxes) -> Mailboxes:
    """The mailboxes of the first FMMU's part and then the others' not among them (those of
    parts the claims took away as well: they need not be idle, but may)."""
    if not others:
        return first
    return first + tuple([m for m in others if m not in first])


def unclaimed(ops: tuple[LogicalOp, ...], lo: int, hi: int, write: bool) -> tuple[LogicalOp, ...]:
    """The parts ``ops`` (:func:`plan_logical`) without frame bytes [lo, hi), which an earlier
    FMMU claimed: a byte-wise part as the runs left, a bit-wise part with the bits of those
    frame bytes out of its mask (of the physical bits, shifted, for a write); a part with no
    bit left goes."""
    out: list[LogicalOp] = []
    for op in ops:
        bytewise, phys, size, shift, mask, at, width = op
        if at >= hi or at + width <= lo:
            out.append(op)
            continue
        if bytewise:
            if lo > at:
                out.append(byte_op(phys, at, lo - at))
            if hi < at + width:
                out.append(byte_op(phys + (hi - at), hi, at + width - hi))
            continue
        x, y = 8 * (max(lo, at) - at), 8 * (min(hi, at + width) - at)  # frame bits from at
        if write:
            x, y = max(0, x + shift), max(0, y + shift)  # physical bits from phys
        left = mask & ~(((1 << (y - x)) - 1) << x) if y > x else mask
        if left:
            out.append(_op(False, phys, size, shift, left, at, width))
    return tuple(out)


def _access(caches: Caches, hit: tuple[Fmmu, ...], cmd: int, lad: int, n: int) -> Access:
    key = (hit, cmd, lad, n)
    found = caches.access.get(key)
    if found is None:
        found = Access(caches, hit, cmd, lad, n)
        remember(caches.access, key, found, PLAN_CACHE_ENTRIES)
    return found


def shared_access(
    caches: Caches,
    fmmus: tuple[Fmmu, ...],
    cmd: int,
    lad: int,
    n: int,
    span: tuple[int, int] | None = None,
) -> Access:
    """The :class:`Access` of a logical access through ``fmmus`` (active FMMUs in register
    order): one per FMMUs the access meets, in order, and access (:attr:`Caches.access`), since
    the others do not change its plan; FMMU tables that differ only elsewhere share it.
    ``span``, the logical bytes the FMMUs map (:func:`decode_fmmus`), spares looking at each
    when the access holds it all: then it meets them all."""
    lo, hi = lad, lad + n
    if span is not None and lo <= span[0] and span[1] <= hi:
        return _access(caches, fmmus, cmd, lad, n)
    return _access(
        caches, tuple([f for f in fmmus if f.log_end > lo and f.log_start < hi]), cmd, lad, n
    )


def table_access(caches: Caches, table: FmmuTable, cmd: int, lad: int, n: int) -> Access:
    """The :class:`Access` of a logical access through the FMMU ``table`` (:func:`fmmu_table`),
    worked out once per table and access (its :data:`Plans`). A table decoded in two parts
    joins the accesses through each (:meth:`Access.joined`, once per pair of them,
    :attr:`Caches.joined`, so that tables whose FMMUs the access does not meet differ share it;
    the others' part's worked out once per part and shared by the ESCs of a configured line,
    whose tables differ in FMMU 0 alone; FMMU 0's by :func:`shared_access`): an access FMMU 0
    does not meet is the others' part's, one the others' span does not meet FMMU 0's.
    Otherwise :func:`shared_access`."""
    plans = table.plans
    key = plans_key(cmd, lad, n)
    found = plans.get(key)
    if found is not None:
        return found
    parts = table.parts
    if parts is None:
        found = shared_access(caches, table.fmmus, cmd, lad, n, table.span)
    else:
        head, rest = parts
        f, span = head.fmmus, rest.span
        if not (f and f[0].log_end > lad and f[0].log_start < lad + n):  # FMMU 0 does not meet it
            found = _part_access(caches, rest, key, cmd, lad, n)
        elif not (rest.fmmus and span[0] < lad + n and span[1] > lad):  # FMMU 0 alone does
            found = shared_access(caches, f, cmd, lad, n, head.span)
        else:  # joined once per pair of parts' accesses, whatever else differs
            others = _part_access(caches, rest, key, cmd, lad, n)
            if not others.hit:  # the others' span meets it, but none of them does
                found = shared_access(caches, f, cmd, lad, n, head.span)
            else:
                pair = (shared_access(caches, f, cmd, lad, n, head.span), others)
                found = caches.joined.get(pair)
                if found is None:
                    joined = Access.joined(pair[0], pair[1])
                    found = remember(caches.joined, pair, joined, PLAN_CACHE_ENTRIES)
    return remember(plans, key, found, PLAN_CACHE_ENTRIES)


def _part_access(caches: Caches, part: FmmuTable, key: int, cmd: int, lad: int, n: int) -> Access:
    found = part.plans.get(key)  # (key: plans_key of the access)
    if found is None:
        found = shared_access(caches, part.fmmus, cmd, lad, n, part.span)
        remember(part.plans, key, found, PLAN_CACHE_ENTRIES)
    return found


class RowAccess(NamedTuple):
    """What the chain may do over the rows of ESCs with their own state in mind
    (:func:`esc_row_access`)."""

    plain: PlainAccess  # the plan, its holes and the plan cut (:func:`esc_row_access`)
    events: int  # the ECAT events (0x0210 bits) its reads of DL or AL status clear
    mailboxes: Mailboxes  # those that must be idle at an ESC for the cut to hold there
    dc: tuple[tuple[int, int], ...]  # the registers [lo, hi) of its one read of DC registers
    shadow: tuple[LogicalOp, ...]  # its write parts that write registers (their shadow)


def _row_access(
    plain: PlainAccess,
    events: int,
    mailboxes: Mailboxes,
    dc: tuple[tuple[int, int], ...],
    shadow: tuple[LogicalOp, ...],
) -> RowAccess:
    """``RowAccess(plain, events, mailboxes, dc, shadow)``, made natively (:data:`_new`)."""
    return _new(RowAccess, (plain, events, mailboxes, dc, shadow))


def esc_row_access(
    plan: LogicalPlan, areas: SmTable, top: int, inert: Callable[[int, int], bool] | None = None
) -> RowAccess | None:
    """What the chain may do over the rows of many ESCs: ``plan`` where all it does is plain
    memory, cut (:class:`PlainAccess`: the plan, the bytes where it does nothing, :data:`Holes`,
    and the plan without them, :func:`cut`), and what each ESC does besides; else None.

    It does nothing in a SyncManager's area that is locked (deactivated by the PDI) or of the
    other direction (ECAT neither reads a write buffer nor writes a read buffer), nor at or
    above ``top`` outside SyncManager areas (process RAM closed, datasheet I 8, 11.2.1). Plain
    is the rest: at or above the registers (0x0F80), and reads of registers: a read of them is
    their committed bytes; and writes of registers where ``inert(address, length)`` says the
    write changes nothing (read-only ones, :meth:`emulator.esc.write_plans.WritePlans.inert`):
    a hole that still counts. A part that meets the buffer of another SyncManager makes the
    access not plain. (Below 0x0F80 the registers are accessed whatever SyncManager area lies
    there.) It is also plain with what each ESC's state decides:

    - reads of DL or AL status: each ESC clears the ECAT events they clear (0x0210 bits,
      :attr:`RowAccess.events`, :func:`emulator.esc.registers.cleared_events`, datasheet I
      Table 3) once the datagram's reads at that ESC are done; a later part that reads the
      event request (0x0210) would see it cleared, and is left to the ESC (None);
    - mailboxes in the direction ECAT accesses them (a read mailbox on the read side, a write
      mailbox on the write side): their areas are cut as holes and the mailboxes listed,
      (SyncManager index, side 0 read / 1 write), in plan order. The cut holds at an ESC only
      while each of them is one ECAT cannot access: a read mailbox empty, a write mailbox full
      (:meth:`emulator.esc.device.EscDevice._mailboxes_idle`), where the access reads or
      writes nothing at all and changes no state ("read/write w. failure", datasheet I
      8.2.1); else the access is the ESC's;
    - one read part that reads DC registers, which run with the clock: each ESC brings them up
      to the frame's time first (:meth:`emulator.esc.dc.DcClock.refresh` of its registers
      [lo, hi), as the ESC does before such a read), then they are read as committed bytes.
      A second such part is left to the ESC: a refresh for one part would change what the
      other reads (a read of the SYNC status clears it, datasheet II 2.22);
    - write parts that write registers (below 0x0F80) where a write changes something: such a
      write goes to the ESC's shadow registers, which take it at the end of the frame
      (datasheet I 3.4), so its registers are cut as holes (a part left with nothing still
      counts, :func:`cut`) and the parts are listed whole, in plan order, for each ESC to put
      the bytes it writes there among its shadow writes (:attr:`EscDevice.pending`: the first
      ``min(end, 0x0F80) - start`` bytes of what the part writes; a bit-wise part merges
      with the registers as committed, which the datagram's reads leave alone but for the
      events they clear, in the event request 0x0210, which ECAT cannot write; a byte
      written into the reset register 0x0040 counts towards a reset,
      :meth:`emulator.esc.device.EscDevice._write_shadow`)."""
    events = 0
    idle: list[tuple[int, int]] = []
    dc: tuple[tuple[int, int], ...] = ()
    shadow: list[LogicalOp] = []
    found: list[PartHoles] = []
    for side, ops in enumerate(plan):  # reads, writes
        for k, op in enumerate(ops):
            lo = op.phys
            hi = lo + op.size
            holes: tuple[tuple[int, int], ...] = ()
            if lo < REGISTER_END:
                if not side:
                    if reads_dc(lo, hi):
                        if dc:
                            return None
                        dc = ((lo, min(hi, REGISTER_END)),)
                    if events and lo <= REG_ECAT_EVENT < hi:
                        return None  # it sees what a read before it cleared: the ESC's order
                    events |= cleared_events(
                        lo, hi
                    )  # once this part is read (its own bytes as they were)
                elif inert is not None and inert(lo, min(hi, REGISTER_END) - lo):
                    holes = ((lo, min(hi, REGISTER_END)),)  # counts: ECAT wrote registers
                else:
                    holes = ((lo, min(hi, REGISTER_END)),)  # counts; written to the shadow
                    shadow.append(op)
            for area in areas:
                start, end = area.start, area.start + area.length
                if start < hi and end > lo:
                    control = area.control
                    if not area.locked and ((control >> 2) & 0x03 == 0x01) == (side == 1):
                        if control & 0x03 != 0x02:
                            return None  # a buffer ECAT accesses (writes/reads): its own rules
                        if (area.number, side) not in idle:
                            idle.append((area.number, side))  # nothing there while it is idle
                    start = max(start, REGISTER_END)
                    if start < end:
                        holes += ((start, end),)
            if hi > top and hi > REGISTER_END:
                holes += ((max(top, REGISTER_END), hi),)
            if holes:
                found.append(_part_holes(side, k, holes))
    every: Holes = tuple(found)
    plain = _plain_access(plan, every, cut(plan, every))
    return _row_access(plain, events, tuple(idle), dc, tuple(shadow))


def cut(plan: LogicalPlan, holes: Holes) -> LogicalPlan:
    """``plan`` without the bytes where it does nothing (:func:`esc_row_access`): byte-wise parts
    as the runs left, bit-wise ones with the holes' bits out of their masks; a part left with
    none goes, unless it wrote registers: then it stays, writing no byte, for the working
    counter."""
    if not holes:
        return plan
    out = (list(plan[0]), list(plan[1]))
    for side, k, parts in reversed(holes):  # from the end: the indices stay valid
        op = plan[side][k]
        left = without(op, parts, side == 1)
        if not left and side == 1 and op.phys < REGISTER_END:  # registers written count
            left = [byte_op(op.phys, op.at, 0)]  # writing no byte
        out[side][k : k + 1] = left
    return tuple(out[0]), tuple(out[1])


def without(op: LogicalOp, holes: Sequence[tuple[int, int]], write: bool) -> list[LogicalOp]:
    """``op`` (:func:`plan_logical`) without its physical bytes in ``holes``: a byte-wise part
    as the runs left; a bit-wise part narrowed to the physical bytes from the first run left to
    the end of the last, and the frame bytes their bits lie in, with the holes' bits out of its
    mask (of the physical bits for a write, of the frame bits for a read); or nothing when no
    byte is left (every byte of a bit-wise part from :func:`plan_logical` holds a mapped bit).
    """
    runs, lo = _outside(op, holes), op.phys
    if op.bytewise:
        return [byte_op(x, op.at + (x - lo), y - x) for x, y in runs]
    if not runs:
        return []
    first, end = runs[0][0], runs[-1][1]
    valid = 0  # the physical bits left, from byte ``first``
    for x, y in runs:
        valid |= ((1 << 8 * (y - x)) - 1) << 8 * (x - first)
    _, _, _, shift, mask, at, width = op
    bit = 8 * (first - lo) - shift  # the frame bit (from byte ``at``) of ``first``'s bit 0
    skip = max(0, bit // 8)  # frame bytes before the first one left
    shift = 8 * skip - bit  # physical bit - frame bit, from ``first`` and ``at + skip``
    width = min(width - skip, -(-(8 * (end - first) - shift) // 8))
    if write:  # a mask of physical bits
        mask = (mask >> 8 * (first - lo)) & valid
    else:  # a mask of frame bits: the valid physical bits where they lie in the frame bytes
        moved = valid >> shift if shift >= 0 else valid << -shift
        mask = (mask >> 8 * skip) & moved & ((1 << 8 * width) - 1)
    return [_op(False, first, end - first, shift, mask, at + skip, width)] if mask else []


def _outside(op: LogicalOp, holes: Sequence[tuple[int, int]]) -> list[tuple[int, int]]:
    """The runs [x, y) of ``op``'s physical bytes outside ``holes`` (:func:`outside`)."""
    return outside(op.phys, op.phys + op.size, holes)


def outside(lo: int, hi: int, holes: Sequence[tuple[int, int]]) -> list[tuple[int, int]]:
    """The runs [x, y) of bytes [lo, hi) outside ``holes`` (in any order, may overlap), in
    order."""
    runs, at = [], lo
    for start, end in sorted(holes):
        if start >= hi:
            break
        if start > at:
            runs.append((at, start))
        at = max(at, end)
        if at >= hi:
            break
    if at < hi:
        runs.append((at, hi))
    return runs


def claim(claimed: list[tuple[int, int]] | None, lo: int, hi: int) -> list[tuple[int, int]]:
    """The runs of [lo, hi) that no lower-numbered FMMU took, now taken (datasheet I 7): a
    lower FMMU's bytes inside the range split it. ``claimed``: the ranges taken so far,
    sorted and apart (None: no other FMMU claims)."""
    if lo >= hi:
        return []
    if claimed is None:
        return [(lo, hi)]
    runs, at = [], lo
    for start, end in claimed:
        if end <= at:
            continue
        if start >= hi:
            break
        if start > at:
            runs.append((at, start))
        at = end
        if at >= hi:
            break
    if at < hi:
        runs.append((at, hi))
    kept = []
    for start, end in claimed:  # in order: those that meet [lo, hi) join it
        if end < lo or start > hi:
            kept.append((start, end))
        else:
            lo, hi = min(lo, start), max(hi, end)
    kept.append((lo, hi))
    kept.sort()
    claimed[:] = kept
    return runs


def bit_span(f: Fmmu, lo: int, hi: int) -> tuple[int, int, int]:
    """Logical bits [b0, b1] of bytes [lo, hi) that FMMU ``f`` maps, and the physical bit
    of b0; b0 > b1 when none (the mapping is clipped to the 64 KiB address space)."""
    log_start, log_end, phys, start_bit, stop_bit, phys_bit = f[:6]
    l0 = log_start * 8 + start_bit
    l1 = min((log_end - 1) * 8 + stop_bit, l0 + f.bits - 1)  # inclusive
    b0, b1 = max(lo * 8, l0), min(hi * 8 - 1, l1)
    return b0, b1, phys * 8 + phys_bit + (b0 - l0)
