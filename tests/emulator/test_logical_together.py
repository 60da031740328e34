"""Logical datagrams that ESCs map onto plain memory with one FMMU plan are done for all of them at
once (:func:`emulator.esc.together.logical_together`, chosen ESC by ESC with
:func:`emulator.esc.mapping.esc_row_access`), and that leaves the same bytes as ESC by ESC
(:meth:`EscDevice.process`, the path of :meth:`EcatChain._pass`): the same returned frame, memory
and event request at every ESC, frame after frame. The FMMU tables aim at what the shortcut takes
over (bit-wise mappings at every bit offset, byte-wise ones, overlapping ones; reads, writes,
both) and at its edges: SyncManager areas, registers (read, with and without side effects, and
written), the end of the address space, and process RAM that an ESC whose EEPROM did not load
keeps closed (datasheet I 11.2.1)."""

from __future__ import annotations

import itertools
import random
import struct
from collections.abc import Sequence

import numpy as np
import pytest
from hypothesis import assume, example, given
from hypothesis import strategies as st
from one_by_one import OneByOne

from emulator.esc import mapping, together, write_plans
from emulator.esc.chain import EcatChain, configure_frames
from emulator.esc.device import EscDevice
from emulator.esc.registers import SM_BYTES, EscConfig
from emulator.slave.sii import SlaveInfo, build_sii
from skinframes import ethercat
from skinframes.ethercat import Command, Datagram, EcatFrame

NODES, SIZE = 12, 8
CLOSED = 5  # the ESC whose EEPROM checksum is wrong: no process RAM from ECAT
# physical starts: user RAM, process RAM, its end; the input SyncManager's area (0x1000 + 8),
# which the shortcut leaves to each ESC, and registers, which it reads unless they are DC
# registers (0x0900+, running with the clock), clearing the events a read of DL status (0x0110)
# or AL status (0x0130) clears, and never writes
PLAIN = (0x0F80, 0x0FF0, 0x1200, 0x1201, 0x1FFF, 0x7000, 0xFFF0, 0xFFFF)
EDGES = (0x0F7C, 0x0F7F, 0x0FFC, 0x1000, 0x1004, 0x0000, 0x0108, 0x0111, 0x012C, 0x0131, 0x08F8)
LOGICAL = (Command.LRD, Command.LWR, Command.LRW)
# SyncManager 1 as a buffer ECAT writes at 0x1200 + 16 (datasheet II 2.14: buffered, direction
# ECAT writes, enabled): ECAT does not read it; the PDI locks it at some ESCs, and the inputs'
# buffer at others, so that logical accesses meet SyncManager areas where they do nothing
WRITE_SM = struct.pack("<HHBBBB", 0x1200, 16, 0x04, 0, 0x01, 0)


def line(kind: type[EcatChain]) -> EcatChain:
    """``NODES`` skin patches configured as a master leaves them, one of them without PDI."""
    devices = []
    for p in range(NODES):
        info = SlaveInfo.skin_patch(SIZE, serial=p + 1)
        image = bytearray(build_sii(info))
        if p == CLOSED:
            image[14] ^= 0xFF  # configuration area checksum
        devices.append(EscDevice(info, sii=bytes(image)))
    chain = kind(devices)
    chain.clock_ns = itertools.count(10**9, 1_234_567).__next__  # DC registers run with it
    for frame in configure_frames(devices[0].info, NODES):
        chain.process_frame(frame)
    chain.process_frame(bwr(0x0808, WRITE_SM))
    for p, dev in enumerate(devices):
        if p % 3 == 1:
            dev.pdi_deactivate_sms((0,), True)  # the inputs' buffer locked
        if p % 4 == 2:
            dev.pdi_deactivate_sms((1,), True)
    return chain


def raise_events(chain: EcatChain) -> None:
    """The DL and AL status events pending at every ESC (0x0210 bits 2 and 3), as a link change
    and a state change leave them, so that a read of DL or AL status has an event to clear."""
    for dev in chain.devices:
        event = dev.registers(0x0210, 1)[0] | 0x0C
        dev.pdi_write(0x0210, bytes((event,)))
        dev.update_irq()


def fmmu(rng: random.Random) -> bytes:
    """One FMMU's registers (datasheet II 2.13): mostly onto plain memory, now and then over an
    edge; byte-wise (bits 0 to 7, physical bit 0) or with any bit offsets; read, write or both;
    now and then inactive."""
    phys = rng.choice(PLAIN) if rng.random() < 0.9 else rng.choice(EDGES)
    bits = (
        (0, 7, 0) if rng.random() < 0.4 else (rng.randrange(8), rng.randrange(8), rng.randrange(8))
    )
    return struct.pack(
        "<IHBBHBBB3x",
        rng.randrange(96),  # logical start
        rng.randrange(1, 48),  # length
        bits[0],  # logical start bit
        bits[1],  # logical stop bit
        phys,
        bits[2],  # physical start bit
        rng.choice((1, 2, 3)),  # read, write, both
        rng.random() < 0.9,  # active
    )


def frame(rng: random.Random) -> bytes:
    """FMMUs configured at every ESC (now and then at one), plain memory filled at some, or
    1-3 logical datagrams."""
    dgs = []
    what = rng.random()
    if what < 0.2:
        at = 0x0600 + 16 * rng.randrange(4)
        if rng.random() < 0.8:
            dgs.append(Datagram(Command.BWR, 0, at, fmmu(rng)))
        else:
            dgs.append(Datagram(Command.APWR, -rng.randrange(NODES) & 0xFFFF, at, fmmu(rng)))
    elif what < 0.35:
        for _ in range(rng.randint(1, 4)):
            ado = rng.choice(PLAIN[:-1]) + rng.randrange(-2, 3)
            data = rng.randbytes(rng.randrange(1, min(64, 0x10000 - ado)))
            dgs.append(Datagram(Command.APWR, -rng.randrange(NODES) & 0xFFFF, ado, data))
    else:
        for _ in range(rng.randint(1, 3)):
            n = rng.randrange(1, 100)
            cmd = rng.choice(LOGICAL)
            dgs.append(Datagram.logical(cmd, rng.randrange(100), rng.randbytes(n)))
    return ethercat.frame(EcatFrame(tuple(dgs))).to_bytes()


def assert_same(fast: EcatChain, reference: EcatChain, data: bytes, what: str) -> None:
    assert fast.process_frame(data) == reference.process_frame(data), what
    assert np.array_equal(fast.memory, reference.memory), what
    for a, b in zip(fast.devices, reference.devices, strict=True):
        assert a.irq == b.irq, what


@pytest.mark.parametrize("least", [1, 3, together.LOGICAL_TOGETHER_MIN])
def test_logical_datagrams_leave_the_same_bytes(
    least: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``least``: the fewest ESCs in a row done at once (fewer go one by one)."""
    monkeypatch.setattr("emulator.esc.chain.LOGICAL_TOGETHER_MIN", least)
    rows: list[int] = []
    shortcut = together.logical_together

    def counted(memory, run, plan, cmd, buf, off, n, *shadow):  # type: ignore[no-untyped-def]
        rows.append(len(run))
        return shortcut(memory, run, plan, cmd, buf, off, n, *shadow)

    monkeypatch.setattr("emulator.esc.chain.logical_together", counted)
    rng = random.Random(least)
    fast, reference = line(EcatChain), line(OneByOne)
    assert not fast.devices[CLOSED].pdi_operational
    for i in range(1_500):
        if i % 20 == 0:
            raise_events(fast)
            raise_events(reference)
        assert_same(fast, reference, frame(rng), f"frame {i}")
    assert len(rows) > 50 and sum(rows) > 500  # the shortcut is taken, a run of 8+ as well
    assert max(rows) == NODES and min(rows) >= least


def test_the_shortcut_is_what_decides(monkeypatch: pytest.MonkeyPatch) -> None:
    """A shortcut that leaves the memory alone fails the comparison: the test sees it."""
    fast, reference = line(EcatChain), line(OneByOne)
    table = struct.pack("<IHBBHBBB3x", 200, 4, 3, 4, 0x0F90, 5, 3, 1)  # bit-wise, read and write
    assert_same(fast, reference, bwr(0x0610, table), "FMMU 1")
    lrw = ethercat.frame(
        EcatFrame((Datagram.logical(Command.LRW, 200, b"\xa5\x5a\xff\x01"),))
    ).to_bytes()
    assert_same(fast, reference, lrw, "LRW")
    assert_same(fast, reference, lrw, "LRW again")

    def reads_only(memory, run, plan, cmd, buf, off, n, *_):  # type: ignore[no-untyped-def]
        return together.logical_together(memory, run, (plan[0], ()), cmd, buf, off, n) * 3

    monkeypatch.setattr("emulator.esc.chain.logical_together", reads_only)
    with pytest.raises(AssertionError):
        assert_same(fast, reference, lrw, "LRW without its writes")


def bwr(ado: int, data: bytes) -> bytes:
    return ethercat.frame(EcatFrame((Datagram(Command.BWR, 0, ado, data),))).to_bytes()


@pytest.mark.parametrize("shift", [-17, -9, -8, -7, -1, 0, 1, 3, 7, 8, 9, 16, 23])
def test_rows_shift_as_integers_do(shift: int) -> None:
    """Row by row, the bytes of ``int.from_bytes(row, "little") >> shift`` (<< for negative),
    cut or zero-extended to the width asked for."""
    rng = np.random.default_rng(shift + 100)
    data = rng.integers(0, 256, (5, 11), np.uint8)
    for width in (1, 4, 11, 14):
        got = together._shifted(data, shift, width)
        for row, out in zip(data, got, strict=True):
            value = int.from_bytes(row.tobytes(), "little")
            value = value >> shift if shift >= 0 else value << -shift
            assert out.tobytes() == (value & ((1 << 8 * width) - 1)).to_bytes(width, "little")


@pytest.mark.parametrize("ends", [(0xFF, 0xFF), (0x1F, 0xF8), (0x00, 0x00), (0x80, 0x01)])
@pytest.mark.parametrize("hole", [False, True])
@pytest.mark.parametrize("width", [4, write_plans._WIDE + 3])
@pytest.mark.parametrize("rows", [1, 3])
def test_masked_bytes_take_the_data_under_the_mask_alone(
    ends: tuple[int, int], hole: bool, width: int, rows: int
) -> None:
    """``width`` bytes from byte 2 on of each of 4 memory rows (rows 1..3 as a slice, or rows
    0 and 3 by index, or row 2 alone) from ``data`` where the little-endian mask has bits, the
    others kept: as integers would do it. The mask is whole bytes between ``ends``, but for
    one byte in the middle (0xF7) with a ``hole``; narrow and wide, from one row of data or
    one per row."""
    mask_bytes = bytearray([ends[0], *[0xFF] * (width - 2), ends[1]])
    if hole:
        mask_bytes[width // 2] = 0xF7
    mask = int.from_bytes(mask_bytes, "little")
    rng = np.random.default_rng(width + rows + ends[0] + hole)
    memory = rng.integers(0, 256, (4, width + 4), np.uint8)
    data = rng.integers(0, 256, (rows, width), np.uint8)
    picked = [1, 2, 3] if rows == 3 else [2]
    for at in (slice(picked[0], picked[-1] + 1), np.array(picked[::2], np.intp)):
        chosen = range(4)[at] if isinstance(at, slice) else at.tolist()
        before = memory.copy()
        expected = memory.copy()
        for row in chosen:
            old = int.from_bytes(expected[row, 2 : 2 + width].tobytes(), "little")
            new = int.from_bytes(data[picked.index(row) % rows].tobytes(), "little")
            value = (old & ~mask) | (new & mask)
            expected[row, 2 : 2 + width] = np.frombuffer(value.to_bytes(width, "little"), np.uint8)
        mine = data if isinstance(at, slice) or rows == 1 else data[::2]
        write_plans.write_masked(memory, at, 2, 2 + width, mine, together._mask(mask, width))
        assert memory.tobytes() == expected.tobytes()
        memory = before


# SyncManager areas (index, start, length, control, PDI-locked) as decode_sms gives them:
# control 0x00 a buffer ECAT reads, 0x04 one ECAT writes (datasheet II 2.14)
LOCKED_READ_BUFFER = mapping.SmEntry(
    0, 0x0F00, 0x90, 0x00, 1
)  # [0x0F00, 0x0F90), partly over registers
WRITE_BUFFER = mapping.SmEntry(1, 0x2000, 2, 0x04, 0)  # [0x2000, 0x2002)


def parts(plan: mapping.LogicalPlan, areas: mapping.SmTable, top: int) -> object:
    """What the ESCs of ``areas`` and memory ``top`` do of ``plan``, holes cut (or None)."""
    found = mapping.esc_row_access(plan, areas, top)
    if found is None:
        return None
    assert not (found.events or found.mailboxes or found.dc or found.shadow)
    assert found.plain.cut == mapping.cut(found.plain.plan, found.plain.holes)
    return found.plain.cut


def test_plain_parts_cut_away_the_bytes_where_an_access_does_nothing() -> None:
    """Hand-worked cuts: a locked buffer is a hole from 0x0F80 on (below it the registers are
    read whatever SyncManager area lies there); ECAT does not read a buffer it writes; process
    RAM above the top is closed. A bit-wise part narrows to the bytes left and loses the holes'
    bits."""
    areas = (LOCKED_READ_BUFFER, WRITE_BUFFER)
    byte_read = mapping.byte_op(0x0F70, 0, 0x30)  # physical [0x0F70, 0x0FA0) to frame 0..47
    # physical bytes 0x1FFE..0x2001, frame bit = physical bit - 3, frame bytes 4..7
    bit_read = mapping.LogicalOp(False, 0x1FFE, 4, 3, 0x0FFF_FFFF, 4, 4)
    got = parts(((byte_read, bit_read), ()), areas, 0x10000)
    # registers 0x0F70-0x0F7F, then 0x0F90-0x0F9F; of the bit-wise part only the physical bits
    # 0-15 (0x1FFE, 0x1FFF) stay: frame bits 0-12, in frame bytes 4 and 5
    assert got == (
        (
            mapping.byte_op(0x0F70, 0, 0x10),
            mapping.byte_op(0x0F90, 0x20, 0x10),
            mapping.LogicalOp(False, 0x1FFE, 2, 3, 0x1FFF, 4, 2),
        ),
        (),
    )
    # written: the write buffer is ECAT's (not plain); elsewhere, the mask keeps physical bits
    bit_write = mapping.LogicalOp(
        False, 0x1FFC, 4, 3, 0xFFFF_FFF0, 4, 4
    )  # physical bytes 0x1FFC..0x1FFF
    top = 0x1FFE  # process RAM closed from 0x1FFE: physical bits 16-31 are a hole
    # physical bits 4-15 from frame bits 1-12 (frame bytes 4, 5)
    cut = (mapping.LogicalOp(False, 0x1FFC, 2, 3, 0xFFF0, 4, 2),)
    assert parts(((), (bit_write,)), (), top) == ((), cut)
    # the last byte closed: physical bits 4-23 from frame bits 1-20 (frame bytes 4-6)
    cut = (mapping.LogicalOp(False, 0x1FFC, 3, 3, 0xFFFFF0, 4, 3),)
    assert parts(((), (bit_write,)), (), 0x1FFF) == ((), cut)
    # a hole in front: a locked buffer [0x0FFC, 0x0FFE) of physical bytes 0x0FFC..0x0FFF
    # (frame bit = physical bit - 3 from frame byte 4, frame bits 0-27 mapped). Physical bits
    # 16-31 are left: frame bits 13-27, which are bits 5-19 from frame byte 5; so physical bit
    # = frame bit - 5 from byte 0x0FFE, in frame bytes 5-7
    front = (mapping.SmEntry(0, 0x0FFC, 2, 0x00, 1),)
    bit_read = mapping.LogicalOp(False, 0x0FFC, 4, 3, 0x0FFF_FFFF, 4, 4)
    assert parts(((bit_read,), ()), front, 0x10000) == (
        (mapping.LogicalOp(False, 0x0FFE, 2, -5, 0x0F_FFE0, 5, 3),),
        (),
    )
    assert parts(((), (bit_write,)), (), 0x1FFC) == ((), ())  # nothing left
    assert parts(((), (mapping.byte_op(0x2000, 0, 2),)), areas, 0x10000) is None
    plan = ((byte_read,), ())
    found = mapping.esc_row_access(plan, (), 0x10000)
    assert found is not None and found.plain == (plan, (), plan)  # nothing to cut


def test_logical_writes_of_res_reset_every_esc() -> None:
    """An FMMU that maps the reset register 0x0040 (datasheet II 2.3): 'R', 'E', 'S' written in
    three frames through it reset every ESC of a line long enough for the joint path, with the
    working counter of a write at each; a write of the read-only bytes beside it changes
    nothing but counts as well."""
    nodes = together.LOGICAL_TOGETHER_MIN + 2
    chain = EcatChain.skin(nodes, SIZE)
    for p in range(nodes):
        apwr = Datagram(Command.APWR, -p & 0xFFFF, 0x0010, struct.pack("<H", 0x1001 + p))
        chain.process_frame(ethercat.frame(EcatFrame((apwr,))).to_bytes())
    # FMMU 0: logical 0x10000, 1 byte, byte-wise onto 0x0040, write; FMMU 1: 0x20000 onto 0x0041
    for at, phys in ((0x0600, 0x0040), (0x0610, 0x0041)):
        chain.process_frame(bwr(at, struct.pack("<IHBBHBBB3x", phys << 8, 1, 0, 7, phys, 0, 2, 1)))

    def lwr(lad: int, data: bytes) -> int:
        frame = ethercat.frame(EcatFrame((Datagram.logical(Command.LWR, lad, data),)))
        back = chain.process_frame(frame.to_bytes())
        assert back is not None
        return ethercat.decode(back[14:])[0].datagrams[0].wkc

    assert lwr(0x4100, b"\xff") == nodes  # read-only: nothing changes
    assert [dev.station for dev in chain.devices] == [0x1001 + p for p in range(nodes)]
    for i, ch in enumerate(b"RES"):
        assert [dev.station for dev in chain.devices][:1] == [0x1001]
        assert lwr(0x4000, bytes([ch])) == nodes, i
    assert {dev.station for dev in chain.devices} == {0}  # reset values


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_logical_writes_of_res_that_differ_from_esc_to_esc_reset_each_esc_they_spell(
    kind: type[EcatChain],
) -> None:
    """Hand-worked: FMMU 0 writes logical 0x4000 into the reset register 0x0040 and FMMU 1
    reads it from user RAM 0x0F80, at every ESC. An LRW of 0x4000 with 'X' in three frames,
    after a BWR of user RAM with 'R', 'E' and 'S' in turn: each ESC reads before it writes
    (datasheet I Table 7), so ESC 0 writes 'X' three times, the others what the ESC before read, 'R', 'E',
    'S' (writes that differ from ESC to ESC, over the rows): every ESC but ESC 0 resets; the
    working counter counts a read and a write at each (3)."""
    nodes = together.LOGICAL_TOGETHER_MIN + 2
    chain = kind.skin(nodes, SIZE)
    for p in range(nodes):
        apwr = Datagram(Command.APWR, -p & 0xFFFF, 0x0010, struct.pack("<H", 0x1001 + p))
        chain.process_frame(ethercat.frame(EcatFrame((apwr,))).to_bytes())
    fmmus = struct.pack("<IHBBHBBB3x", 0x4000, 1, 0, 7, 0x0040, 0, 2, 1)
    fmmus += struct.pack("<IHBBHBBB3x", 0x4000, 1, 0, 7, 0x0F80, 0, 1, 1)
    chain.process_frame(bwr(0x0600, fmmus))
    for ch in b"RES":  # user RAM set by the frame itself: three frames in a row
        ram = Datagram(Command.BWR, 0, 0x0F80, bytes([ch]))
        lrw = Datagram.logical(Command.LRW, 0x4000, b"X")
        back = chain.process_frame(ethercat.frame(EcatFrame((ram, lrw))).to_bytes())
        assert back is not None
        assert ethercat.decode(back[14:])[0].datagrams[1].wkc == 3 * nodes
    assert [dev.station for dev in chain.devices] == [0x1001] + [0] * (nodes - 1)


def on_their_own(
    monkeypatch: pytest.MonkeyPatch, devices: Sequence[EscDevice] | None = None
) -> list[int]:
    """From now on, the positions of the ESCs (of ``devices``, else any) that do a datagram on
    their own (:meth:`EscDevice.process`), in the order they do."""
    alone: list[int] = []
    process = EscDevice.process

    def counted(self: EscDevice, *args: int | bytearray) -> tuple[int, int]:
        if devices is None or self in devices:
            alone.append(self.position)
        return process(self, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(EscDevice, "process", counted)
    return alone


def sent(chain: EcatChain, datagram: Datagram) -> Datagram:
    """``datagram`` alone in a frame through ``chain``, as it comes back."""
    back = chain.process_frame(ethercat.frame(EcatFrame((datagram,))).to_bytes())
    assert back is not None
    (d,) = ethercat.decode(back[14:])[0].datagrams
    return d


def logical(chain: EcatChain, cmd: Command, lad: int, data: bytes) -> Datagram:
    """One logical datagram through ``chain``, as it comes back."""
    return sent(chain, Datagram.logical(cmd, lad, data))


def lrd(chain: EcatChain, lad: int, n: int) -> Datagram:
    return logical(chain, Command.LRD, lad, bytes(n))


def read_fmmu(lad: int, phys: int, n: int) -> bytes:
    """An FMMU's registers (datasheet II 2.13): logical ``lad``, ``n`` bytes, byte-wise onto
    ``phys``, read, active."""
    return struct.pack("<IHBBHBBB3x", lad, n, 0, 7, phys, 0, 1, 1)


def write_fmmu(lad: int, phys: int, n: int) -> bytes:
    """As :func:`read_fmmu`, but writing."""
    return struct.pack("<IHBBHBBB3x", lad, n, 0, 7, phys, 0, 2, 1)


def test_reads_of_al_status_clear_its_event_over_the_rows(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """An FMMU onto AL status (0x0130) at every ESC: an LRD of it is done over the rows of all
    of them (logical_together) and returns the last ESC's AL status, OP (0x08); every ESC has
    read it, so every ESC's AL status event (0x0210 bit 3) is cleared and its DL status event
    (bit 2) is not (datasheet I Table 3)."""
    runs: list[int] = []
    shortcut = together.logical_together

    def counted(memory, rows, *args):  # type: ignore[no-untyped-def]
        runs.append(len(rows))
        return shortcut(memory, rows, *args)

    monkeypatch.setattr("emulator.esc.chain.logical_together", counted)
    chain = line(EcatChain)
    chain.process_frame(bwr(0x0630, read_fmmu(0x4000, 0x0130, 2)))  # FMMU 3
    raise_events(chain)
    d = lrd(chain, 0x4000, 2)
    assert (d.data, d.wkc) == (b"\x08\x00", NODES)
    assert runs == [NODES]
    assert [dev.registers(0x0210, 1)[0] & 0x0C for dev in chain.devices] == [0x04] * NODES


@pytest.mark.parametrize("order", ["AL status first", "event request first", "one part"])
def test_a_read_of_the_event_request_sees_what_the_reads_before_it_cleared(order: str) -> None:
    """AL status (0x0130) and the event request (0x0210) read into two frame bytes: by FMMU 1 and
    FMMU 2 in either order, or by one FMMU onto 0x0130-0x0211 (bit-wise from bit 0: physical
    bytes in frame bytes 0 to 225). An ESC reads through its FMMUs in their order, and clears
    the AL status event once a part that read AL status is read: the event request it returns
    has bit 3 cleared only when AL status was read by an FMMU before."""
    chain = line(EcatChain)
    raise_events(chain)
    if order == "one part":
        chain.process_frame(bwr(0x0610, read_fmmu(0x4000, 0x0130, 0x0212 - 0x0130)))
    else:
        first, second = (0x0130, 0x0210) if order == "AL status first" else (0x0210, 0x0130)
        chain.process_frame(bwr(0x0610, read_fmmu(0x4000, first, 1)))
        chain.process_frame(bwr(0x0620, read_fmmu(0x4001, second, 1)))
    last = chain.devices[-1]
    events = last.registers(0x0210, 1)[0]
    assert events & 0x0C == 0x0C
    if order == "one part":
        d = lrd(chain, 0x4000, 0x0212 - 0x0130)
        got = d.data[0], d.data[0x0210 - 0x0130]
    else:
        d = lrd(chain, 0x4000, 2)
        got = (d.data[0], d.data[1]) if order == "AL status first" else (d.data[1], d.data[0])
    assert got == (0x08, events & ~0x08 if order == "AL status first" else events)
    assert d.wkc == NODES
    assert last.registers(0x0210, 1)[0] == events & ~0x08


def test_fmmu_tables_that_differ_only_elsewhere_share_an_access() -> None:
    """The plan of a logical access depends on the FMMUs it meets, in order, alone: tables that
    differ in another FMMU share one (and its plain parts); one that differs in a met FMMU
    does not."""
    caches = mapping.Caches()  # a chain's
    met = mapping.Fmmu(0x100, 0x110, 0x1200, 0, 7, 0, 1, 1, True, 0)  # logical 0x100- on 0x1200
    other = mapping.Fmmu(0x8000, 0x8004, 0x1400, 0, 7, 0, 1, 0, True, 0)
    moved = other._replace(phys=0x1500)
    lrw = int(Command.LRW)
    a = mapping.shared_access(caches, (met, other), lrw, 0x100, 8)
    b = mapping.shared_access(caches, (met, moved), lrw, 0x100, 8)
    c = mapping.shared_access(caches, (met._replace(phys=0x1300),), lrw, 0x100, 8)
    assert a is b and a is not c
    assert a.plan == (((mapping.byte_op(0x1200, 0, 8),), (mapping.byte_op(0x1200, 0, 8),)))


@pytest.mark.parametrize(
    ("holes", "left"),
    [
        ([(0x1001, 0x1010)], True),  # byte 0x1000
        ([(0x1000, 0x1010)], False),
        ([(0x1000, 0x1005), (0x1006, 0x1010)], True),  # byte 0x1005
        ([(0x1006, 0x1010), (0x1000, 0x1005)], True),  # in any order
        ([(0x1000, 0x1008), (0x1004, 0x1010)], False),  # overlapping holes
        ([(0x0FF0, 0x1020)], False),
        ([(0x1000, 0x100F)], True),  # the last byte
    ],
)
def test_a_part_leaves_bytes_outside_its_holes(holes: list[tuple[int, int]], left: bool) -> None:
    byte_wise = mapping.byte_op(0x1000, 0, 0x10)  # physical [0x1000, 0x1010)
    # the same physical bytes, bits 3-127 from frame bits 0-124 (frame bytes 0-15)
    bit_read = mapping.LogicalOp(False, 0x1000, 0x10, 3, (1 << 125) - 1, 0, 16)
    bit_write = mapping.LogicalOp(False, 0x1000, 0x10, 3, ((1 << 125) - 1) << 3, 0, 16)
    assert bool(mapping.without(byte_wise, holes, False)) is left
    assert bool(mapping.without(bit_read, holes, False)) is left
    assert bool(mapping.without(bit_write, holes, True)) is left


@given(st.lists(st.tuples(st.integers(0, 40), st.integers(0, 40)), max_size=8))
def test_claims_leave_the_bytes_no_earlier_claim_took(ranges: list[tuple[int, int]]) -> None:
    """FMMU claims in register order (datasheet I 7): each gets the maximal runs of its range
    that no earlier claim took, as sets of bytes say."""
    claimed: list[tuple[int, int]] = []
    taken: set[int] = set()
    for lo, hi in ranges:
        free = [x for x in range(lo, hi) if x not in taken]
        runs: list[tuple[int, int]] = []
        for x in free:
            if runs and runs[-1][1] == x:
                runs[-1] = (runs[-1][0], x + 1)
            else:
                runs.append((x, x + 1))
        assert mapping.claim(claimed, lo, hi) == runs
        taken |= set(range(lo, hi))
        assert claimed == sorted(claimed)
        assert all(a[1] < b[0] for a, b in itertools.pairwise(claimed))  # apart


def bit_pairs(plan: mapping.LogicalPlan) -> tuple[set[tuple[int, int]], ...]:
    """What a plan (cut) maps, read and written: the pairs (frame bit, physical bit), as the
    parts' fields say (LogicalOp): byte-wise, physical a, c bytes at frame offset e; bit-wise,
    physical bytes from a, physical bit = frame bit + c, mask d of frame bits from byte e (a
    read) or of physical bits from byte a (a write)."""
    out: tuple[set[tuple[int, int]], ...] = (set(), set())
    for side, ops in enumerate(plan):
        for bytewise, a, b, c, d, e, _ in ops:
            if bytewise:
                out[side].update((8 * e + i, 8 * a + i) for i in range(8 * b))
            elif side == 0:
                out[0].update(
                    (8 * e + j, 8 * a + j + c) for j in range(d.bit_length()) if d >> j & 1
                )
            else:
                out[1].update(
                    (8 * e + p - c, 8 * a + p) for p in range(d.bit_length()) if d >> p & 1
                )
    return out


class Inert:
    """Register write plans under which writes from 0x0E00 on change nothing."""

    def inert(self, addr: int, n: int) -> bool:
        return addr >= 0x0E00


# physical starts: the first FMMU's anywhere, the others' mostly in RAM, near SyncManager areas
FIRST_PHYS = (0x0000, 0x0130, 0x08FC, 0x0990, 0x0E10, 0x0F7E, 0x1000, 0x1100, 0xFFF8)
OTHER_PHYS = (0x1000, 0x1004, 0x1010, 0x1100, 0x1103, 0x17FC, 0xFFF8, 0x0F7E, 0x0910)


def an_fmmu(phys: st.SearchStrategy[int]) -> st.SearchStrategy[tuple[int, ...]]:
    """(logical start, length, (start bit, stop bit, physical bit), physical start, kind)."""
    return st.tuples(
        st.integers(0, 40),
        st.integers(1, 24),
        st.sampled_from([(0, 7, 0), (0, 7, 0), (3, 4, 5), (7, 0, 1), (5, 6, 7), (0, 7, 3)]),
        phys,
        st.integers(1, 3),  # read, write, both
    )


def sm_areas() -> st.SearchStrategy[mapping.SmTable]:
    """Up to 2 SyncManager areas as decode_sms gives them (index, start, length, control,
    PDI-locked) near the FMMUs' physical starts: buffers ECAT reads or writes, mailboxes."""
    entry = st.tuples(
        st.sampled_from([0x1000, 0x1008, 0x1104, 0x1800]),
        st.integers(2, 12),
        st.sampled_from([0x00, 0x04, 0x02, 0x06]),  # ECAT reads, writes; mailboxes
        st.booleans(),  # PDI-locked
    )
    return st.lists(entry, max_size=2).map(
        lambda sms: tuple(
            mapping.SmEntry(k, start, length, control, int(locked))
            for k, (start, length, control, locked) in enumerate(sms)
        )
    )


def assert_maps_as_whole(
    access: mapping.Access, hit: tuple[mapping.Fmmu, ...], areas: mapping.SmTable, top: int
) -> mapping.RowAccess | None:
    """``access`` (rows asked at ``areas``, ``top``) against the whole plan of ``hit``
    (plan_logical with its claims, then esc_row_access): plain alike, the same frame and
    physical bits read and written, the same events cleared, parts on the same sides (the
    working counter), and every mailbox the whole plan meets among those that must be idle
    (the first's claims may leave the others fewer mailboxes to meet than they list); the
    whole plan's row access is returned."""
    cmd, lad, n = access.cmd, access.lad, access.n
    whole = mapping.esc_row_access(
        mapping.plan_logical(hit, cmd, lad, n), areas, top, Inert().inert
    )
    if whole is None:
        assert access.cut is None
        return None
    assert access.cut is not None
    assert bit_pairs(access.cut) == bit_pairs(whole[0][2])
    assert access.events == whole[1]
    assert [bool(side) for side in access.cut] == [bool(side) for side in whole[0][2]]
    assert set(whole[2]) <= set(access.mailboxes)
    assert (access.dc, access.shadow) == (whole.dc, whole.shadow)
    return whole


@given(
    an_fmmu(st.sampled_from(FIRST_PHYS)),
    st.lists(an_fmmu(st.sampled_from(OTHER_PHYS)), min_size=1, max_size=3),
    sm_areas(),
    st.sampled_from(LOGICAL),
    st.integers(0, 20),
    st.integers(1, 40),
    st.sampled_from([0x1008, 0x10000]),
)
@example(  # hand-worked: FMMU 1 alone meets a read mailbox at 0x1000, which must be idle
    (0, 2, (0, 7, 0), 0x1800, 1),
    [(2, 2, (0, 7, 0), 0x1000, 1)],
    (mapping.SmEntry(0, 0x1000, 8, 0x02, 0),),
    Command.LRD,
    0,
    4,
    0x10000,
)
def test_the_first_fmmu_worked_apart_maps_what_the_whole_plan_maps(
    first: tuple[int, ...],
    others: list[tuple[int, ...]],
    areas: mapping.SmTable,
    cmd: Command,
    lad: int,
    n: int,
    top: int,
) -> None:
    """An access through several FMMUs, the first worked out apart from the others
    (:meth:`mapping.Access.rows`), maps what the whole plan maps and is as plain
    (:func:`assert_maps_as_whole`)."""
    caches = mapping.Caches()  # a chain's
    table = b"".join(
        struct.pack("<IHBBHBBB3x", log, length, bits[0], bits[1], phys, bits[2], kind, 1)
        for log, length, bits, phys, kind in (first, *others)
    )
    decoded, _ = mapping.decode_fmmus(caches, table)
    hit = tuple(f for f in decoded if not (f.log_end <= lad or f.log_start >= lad + n))
    # meets the others first
    mapping.Access(caches, hit, int(cmd), lad, n).rows(areas, top, Inert())
    access = mapping.Access(caches, hit, int(cmd), lad, n)  # another ESC's, alike
    access.rows(areas, top, Inert())
    assert_maps_as_whole(access, hit, areas, top)


@given(
    an_fmmu(st.sampled_from(FIRST_PHYS)),
    st.lists(an_fmmu(st.sampled_from(OTHER_PHYS)), min_size=1, max_size=3),
    st.lists(sm_areas(), min_size=1, max_size=3),
    st.sampled_from(LOGICAL),
    st.integers(0, 8),
    st.integers(1, 12),
)
@example(  # hand-worked: FMMU 1 reads 0x1000 into frame byte 0, plain memory at the first
    # table; at the second a SyncManager area the PDI locked lies there, where it reads nothing
    (1, 1, (0, 7, 0), 0x0000, 1),
    [(0, 1, (0, 7, 0), 0x1000, 1)],
    [(), (mapping.SmEntry(0, 0x1000, 2, 0x00, 1),)],
    Command.LRD,
    0,
    1,
)
def test_first_fmmus_of_a_line_take_what_the_others_leave_them(
    first: tuple[int, ...],
    others: list[tuple[int, ...]],
    tables: list[mapping.SmTable],
    cmd: Command,
    lad: int,
    step: int,
) -> None:
    """ESCs of a configured line, each mapping its own logical bytes with FMMU 0 (``step``
    bytes further on at each, the third one byte more), with the same other FMMUs: their
    joined accesses worked out from FMMU 0's access and the others' one shared
    (:meth:`mapping.Access.joined`), each asked at one table and top after another and back,
    map what each whole plan maps."""
    caches = mapping.Caches()  # a chain's
    log, length, bits, phys, kind = first
    rows = [(log + k * step, length + k // 2, bits, phys, kind) for k in range(3)]  # 2 sizes
    table = b"".join(
        struct.pack("<IHBBHBBB3x", log_, length_, bits_[0], bits_[1], phys_, bits_[2], kind_, 1)
        for log_, length_, bits_, phys_, kind_ in (*rows, *others)
    )
    decoded, _ = mapping.decode_fmmus(caches, table)
    assume(len(decoded) == len(rows) + len(others))  # none clipped away
    mine, theirs = decoded[: len(rows)], decoded[len(rows) :]
    n = max(f[1] for f in mine) - lad + 2
    hit = tuple(f for f in theirs if not (f.log_end <= lad or f.log_start >= lad + n))
    assume(hit and all(lad < f[0] for f in mine))
    shared, inert = mapping.Access(caches, hit, int(cmd), lad, n), Inert()  # (one write plan)
    tops = (0x10000, 0x1008, 0x10000)  # each change alone: the tables, the top, FMMU 0's size
    asked = [(areas, top) for top in tops for areas in (*tables, tables[0])]
    for f in mine:
        own = mapping.Access(caches, (f,), int(cmd), lad, n)
        for areas, top in asked:
            access = mapping.Access.joined(own, shared)
            access.rows(areas, top, inert)
            assert_maps_as_whole(access, (f, *hit), areas, top)


def test_the_first_fmmu_claims_its_frame_bytes_from_the_others_cut(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Hand-worked: FMMU 0 reads AL status (0x0130, 2 bytes) into logical 0x10-0x11; FMMU 1 maps
    logical 0x10-0x13 bit-wise onto physical bits from 0x1100 bit 4, read and write. An LRW of
    0x10-0x13: FMMU 0 reads frame bytes 0-1 and clears the AL status event (0x08); FMMU 1 reads
    only frame bytes 2-3 (its cut keeps its parts and loses frame bits 0-15 from its mask) and
    writes all 4 bytes (FMMU 0 claims nothing among the writes) into physical bits 4-35.
    Once another ESC's access met FMMU 1, neither the plan of both FMMUs nor their holes are
    worked out: the first FMMU's plan and the others' cut are."""
    caches = mapping.Caches()  # a chain's
    first = mapping.Fmmu(0x10, 0x12, 0x0130, 0, 7, 0, 1, 0, True, 8 * (0x10000 - 0x0130))
    other = mapping.Fmmu(0x10, 0x14, 0x1100, 0, 7, 4, 1, 1, False, 8 * (0x10000 - 0x1100) - 4)
    whole: list[object] = []
    planned = mapping.plan_logical

    def plan(fmmus, cmd, lad, n):  # type: ignore[no-untyped-def]
        if len(fmmus) > 1:
            whole.append(fmmus)
        return planned(fmmus, cmd, lad, n)

    monkeypatch.setattr(mapping, "plan_logical", plan)
    lrw = int(Command.LRW)
    elsewhere = first._replace(
        log_start=0x100, log_end=0x102
    )  # another ESC's FMMU 0, not in the datagram
    mapping.Access(caches, (elsewhere, other), lrw, 0x10, 4).rows((), 0x10000, Inert())
    whole.clear()  # that first access of FMMU 1 worked out the whole plan
    access = mapping.Access(caches, (first, other), lrw, 0x10, 4)
    access.rows((), 0x10000, Inert())
    assert access.cut == (
        (mapping.byte_op(0x0130, 0, 2), mapping.LogicalOp(False, 0x1100, 5, 4, 0xFFFF_0000, 0, 4)),
        (mapping.LogicalOp(False, 0x1100, 5, 4, 0xF_FFFF_FFF0, 0, 4),),
    )
    assert access.events == 0x08
    assert whole == []


def test_a_write_of_inert_registers_counts_whatever_the_claims_leave() -> None:
    """Hand-worked: FMMU 1 writes logical 0x10-0x13 onto 0x0F7E-0x0F81 (two registers whose write
    changes nothing, then two bytes of user RAM); FMMU 0 claims logical 0x12-0x13 and writes them
    into a buffer the PDI locked. An LWR of 0x10-0x13 writes no byte, but FMMU 1 writes the
    registers (a part that writes no byte, and counts in the working counter), however the
    others' part is worked out."""
    caches = mapping.Caches()  # a chain's
    first = mapping.Fmmu(0x12, 0x14, 0x2000, 0, 7, 0, 0, 1, True, 8 * (0x10000 - 0x2000))
    other = mapping.Fmmu(0x10, 0x14, 0x0F7E, 0, 7, 0, 0, 1, True, 8 * (0x10000 - 0x0F7E))
    locked = (mapping.SmEntry(0, 0x2000, 2, 0x04, 1),)
    lwr = int(Command.LWR)
    elsewhere = first._replace(
        log_start=0x100, log_end=0x102
    )  # another ESC's FMMU 0, not in the datagram
    mapping.Access(caches, (elsewhere, other), lwr, 0x10, 4).rows(locked, 0x10000, Inert())
    access = mapping.Access(caches, (first, other), lwr, 0x10, 4)
    access.rows(locked, 0x10000, Inert())
    assert access.cut == ((), (mapping.byte_op(0x0F7E, 0, 0),))


@given(
    st.lists(
        st.lists(
            st.sampled_from(
                [
                    bytes(16),  # inactive
                    struct.pack("<IHBBHBBB3x", 8, 8, 0, 7, 0x1000, 0, 1, 1),
                    struct.pack("<IHBBHBBB3x", 16, 8, 0, 7, 0x1000, 0, 2, 1),
                    struct.pack("<IHBBHBBB3x", 0, 35039, 5, 6, 0x0F00, 7, 1, 1),
                    struct.pack("<IHBBHBBB3x", 0xFFFF_FFE7, 25, 2, 6, 0, 1, 2, 1),
                    struct.pack("<IHBBHBBB3x", 40, 4, 0, 7, 0xFFFE, 0, 3, 1),
                    struct.pack("<IHBBHBBB3x", 40, 4, 0, 7, 0x1100, 0, 3, 0),  # not active
                ]
            ),
            min_size=1,
            max_size=16,
        ),
        min_size=1,
        max_size=4,
    )
)
def test_fmmu_tables_decoded_in_parts_are_decoded_whole(tables: list[list[bytes]]) -> None:
    """FMMU 0 and the others decoded apart, each once (decode_fmmus), give the FMMUs and the
    span of the whole table decoded at once (decode_entries), tables after tables that share
    their parts."""
    caches = mapping.Caches()  # a chain's
    for entries in tables:
        table = b"".join(entries)
        assert mapping.decode_fmmus(caches, table) == mapping.decode_entries(table)


@given(
    st.one_of(st.none(), an_fmmu(st.sampled_from(FIRST_PHYS))),
    st.lists(st.one_of(st.none(), an_fmmu(st.sampled_from(OTHER_PHYS))), max_size=3),
    sm_areas(),
    st.sampled_from(LOGICAL),
    st.integers(0, 20),
    st.integers(1, 40),
)
def test_an_access_through_a_table_in_parts_is_the_access_of_the_fmmus_it_meets(
    first: tuple[int, ...] | None,
    others: list[tuple[int, ...] | None],
    areas: mapping.SmTable,
    cmd: Command,
    lad: int,
    n: int,
) -> None:
    """table_access of an FMMU table decoded as FMMU 0 and the others (None: an inactive
    FMMU) meets the FMMUs the whole table meets, in register order, plans what plan_logical
    plans through them, and works out over the rows what an access through them alone works
    out; twice asked, it is one object."""
    caches = mapping.Caches()  # a chain's

    def entry(f: tuple[int, ...] | None) -> bytes:
        if f is None:
            return bytes(16)
        log, length, bits, phys, kind = f
        return struct.pack("<IHBBHBBB3x", log, length, bits[0], bits[1], phys, bits[2], kind, 1)

    raw = b"".join(entry(f) for f in (first, *others, None))  # two parts, at least
    table = mapping.fmmu_table(caches, raw)
    decoded, _ = mapping.decode_entries(raw)
    hit = tuple(f for f in decoded if f[1] > lad and f[0] < lad + n)
    found = mapping.table_access(caches, table, int(cmd), lad, n)
    assert found.hit == hit
    assert found.plan == mapping.plan_logical(hit, int(cmd), lad, n)
    alone = mapping.Access(caches, hit, int(cmd), lad, n)
    for access in (alone, found):
        access.rows(areas, 0x10000, Inert())
    assert (found.cut is None) == (alone.cut is None)
    if found.cut is not None and alone.cut is not None:
        assert bit_pairs(found.cut) == bit_pairs(alone.cut)
        assert (found.events, found.dc, found.shadow) == (alone.events, alone.dc, alone.shadow)
        assert set(alone.mailboxes) <= set(found.mailboxes)
    assert mapping.table_access(caches, table, int(cmd), lad, n) is found


def test_tables_that_differ_in_fmmu_0_share_the_access_fmmu_0_does_not_meet() -> None:
    """Hand-worked: two ESCs of a configured line, each mapping its own 8 logical bytes with
    FMMU 0 (at 0 and at 8, onto 0x1100) and logical 0x100-0x103 alike with FMMU 1 (onto
    0x1000). An LWR of 0x100-0x103 meets FMMU 1 alone at both: one access. An LRD of 0-15
    meets each ESC's FMMU 0: an access of each, their reads 8 bytes apart in the frame."""
    caches = mapping.Caches()  # a chain's
    fmmu1 = struct.pack("<IHBBHBBB3x", 0x100, 4, 0, 7, 0x1000, 0, 2, 1)
    tables = [
        mapping.fmmu_table(
            caches, struct.pack("<IHBBHBBB3x", log, 8, 0, 7, 0x1100, 0, 1, 1) + fmmu1
        )
        for log in (0, 8)
    ]
    lwr, lrd = int(Command.LWR), int(Command.LRD)
    a, b = (mapping.table_access(caches, t, lwr, 0x100, 4) for t in tables)
    assert a is b
    assert a.plan == ((), (mapping.byte_op(0x1000, 0, 4),))
    a, b = (mapping.table_access(caches, t, lrd, 0, 16) for t in tables)
    assert a.plan == ((mapping.byte_op(0x1100, 0, 8),), ())
    assert b.plan == ((mapping.byte_op(0x1100, 8, 8),), ())


def test_tables_that_differ_in_an_fmmu_an_access_does_not_meet_share_it() -> None:
    """Hand-worked: two tables with FMMU 0 mapping logical 0-7 onto 0x1100 and FMMU 1 logical
    8-11 onto 0x1000, FMMU 2 mapping logical 0x100-0x103 onto 0x1200 in one and onto 0x1300 in
    the other. An LRD of 0-11 meets FMMUs 0 and 1 alone: one access (joined once), which reads
    0x1100 into frame bytes 0-7 and 0x1000 into 8-11."""
    caches = mapping.Caches()  # a chain's
    head = struct.pack("<IHBBHBBB3x", 0, 8, 0, 7, 0x1100, 0, 1, 1)
    fmmu1 = struct.pack("<IHBBHBBB3x", 8, 4, 0, 7, 0x1000, 0, 1, 1)
    tables = [
        mapping.fmmu_table(
            caches, head + fmmu1 + struct.pack("<IHBBHBBB3x", 0x100, 4, 0, 7, phys, 0, 1, 1)
        )
        for phys in (0x1200, 0x1300)
    ]
    lrd = int(Command.LRD)
    a, b = (mapping.table_access(caches, t, lrd, 0, 12) for t in tables)
    assert a is b
    assert a.plan == ((mapping.byte_op(0x1100, 0, 8), mapping.byte_op(0x1000, 8, 4)), ())


def test_the_esc_leaves_to_the_chain_what_it_does_over_the_rows() -> None:
    """Frame after frame of random FMMUs, an LRD whose plan cut holds at an ESC now
    (EscDevice._row_cut: plain, its mailboxes idle) is left to the chain untouched
    (EscDevice._logical_unless_rows returns the access, having read nothing); one that does
    not hold is done by the ESC. An FMMU that reads AL status is over the rows too, its event
    (0x0210 bit 3, datasheet I Table 3) cleared by each ESC."""
    chain = line(EcatChain)
    rng = random.Random(5)
    lrd_ = int(Command.LRD)
    seen = {"left": 0, "done": 0}
    for _ in range(200):
        chain.process_frame(frame(rng))
        lad, n = rng.randrange(100), rng.randrange(1, 100)
        data = rng.randbytes(n)
        for dev in chain.devices:
            found = dev._access(lrd_, lad, n)
            if dev._row_cut(found) is None:
                seen["done"] += 1
                continue
            untouched = bytearray(data)
            assert dev._logical_unless_rows(lrd_, lad, untouched, 0, n) is found
            assert untouched == data
            seen["left"] += 1
    assert seen["left"] > 100 and seen["done"] > 100, seen
    chain.process_frame(bwr(0x0630, read_fmmu(0x4000, 0x0130, 2)))  # FMMU 3 reads AL status
    for dev in chain.devices:
        found = dev._access(lrd_, 0x4000, 2)
        assert found.cut is not None and found.events == 0x08


def test_an_lrd_counts_an_esc_whose_last_part_reads_nothing() -> None:
    """An LRD of 2 bytes: the last ESC reads byte 1; the one before reads byte 0 through FMMU 0
    and would read byte 1 through FMMU 1, which maps a buffer its PDI locked (a hole). Worked from
    the last back, every bit is read once the first ESC's FMMU 0 is done: its FMMU 1 reads
    nothing, yet the ESC read byte 0 and counts (working counter 2, as ESC by ESC)."""
    chains = [kind.configured(2, SIZE) for kind in (EcatChain, OneByOne)]
    for chain in chains:
        first, last = chain.devices
        first.pdi_deactivate_sms((0,), True)  # the inputs' buffer at 0x1000: locked
        for dev, fmmus in (
            (first, ((0x8000, 0x1100), (0x8001, 0x1000))),
            (last, ((0x8001, 0x1100), None)),
        ):
            dev.pdi_write(0x1100, bytes((0xA0 + dev.position,)))
            for k, fmmu in enumerate(fmmus):
                regs = bytes(16)
                if fmmu is not None:  # one byte, byte-wise, read, active
                    regs = struct.pack("<IHBBHBBB3x", fmmu[0], 1, 0, 7, fmmu[1], 0, 1, 1)
                apwr = Datagram(Command.APWR, -dev.position & 0xFFFF, 0x0600 + 16 * k, regs)
                chain.process_frame(ethercat.frame(EcatFrame((apwr,))).to_bytes())
    lrd = ethercat.frame(EcatFrame((Datagram.logical(Command.LRD, 0x8000, bytes(2)),))).to_bytes()
    fast, reference = (chain.process_frame(lrd) for chain in chains)
    assert fast == reference
    assert fast is not None
    (d,) = ethercat.decode(fast[14:])[0].datagrams
    assert (d.data, d.wkc) == (bytes((0xA0, 0xA1)), 2)


def test_broadcasts_of_memory_keep_to_what_each_esc_opens() -> None:
    """A BWR and a BRD of user and process RAM, at the chain as every ESC in turn would do
    them, keep to what each ESC opens to ECAT. Hand-worked: a BWR of
    11 22 33 44 at 0x0FF0 (user RAM) writes at all 12 ESCs; one at the input buffer (0x1000, a
    read SyncManager) writes nothing (0); one of 55 66 at 0x1300 (process RAM) writes at the 11
    ESCs whose EEPROM loaded, not at the one whose did not; a BRD of 0x12FF + 4 then reads
    00 55 66 00 from those 11."""
    fast, reference = line(EcatChain), line(OneByOne)

    def both(cmd: Command, ado: int, data: bytes) -> Datagram:
        f = ethercat.frame(EcatFrame((Datagram(cmd, 0, ado, data),))).to_bytes()
        back = fast.process_frame(f)
        assert back == reference.process_frame(f)
        assert np.array_equal(fast.memory, reference.memory)
        assert back is not None
        (d,) = ethercat.decode(back[14:])[0].datagrams
        return d

    assert both(Command.BWR, 0x0FF0, b"\x11\x22\x33\x44").wkc == NODES
    assert {fast.memory[p, 0x0FF0:0x0FF4].tobytes() for p in range(NODES)} == {b"\x11\x22\x33\x44"}
    assert both(Command.BWR, 0x1000, b"\x55\x66").wkc == 0
    assert both(Command.BWR, 0x1300, b"\x55\x66").wkc == NODES - 1
    written = [fast.memory[p, 0x1300:0x1302].tobytes() for p in range(NODES)]
    assert written == [b"\x00\x00" if p == CLOSED else b"\x55\x66" for p in range(NODES)]
    read = both(Command.BRD, 0x12FF, bytes(4))
    assert (read.wkc, read.data) == (NODES - 1, b"\x00\x55\x66\x00")


# SyncManager 2 a read mailbox at 0x7000 + 16, SyncManager 3 a write mailbox at 0x7100 + 16
# (datasheet II 2.14: control bits 0-1 = 10 mailbox, bits 2-3 = 00 ECAT reads, 01 ECAT writes)
MAILBOXES = struct.pack("<HHBBBB", 0x7000, 16, 0x02, 0, 0x01, 0) + struct.pack(
    "<HHBBBB", 0x7100, 16, 0x06, 0, 0x01, 0
)
MAILBOX_PHYS = (0x6FF8, 0x7000, 0x7004, 0x700F, 0x70F8, 0x7100, 0x7108, 0x0F80)


def mailbox_fmmu(rng: random.Random) -> bytes:
    """An FMMU as :func:`fmmu` gives, onto or beside the mailboxes of :data:`MAILBOXES`."""
    table = bytearray(fmmu(rng))
    struct.pack_into("<H", table, 8, rng.choice(MAILBOX_PHYS))
    return bytes(table)


def with_mailboxes(chain: EcatChain) -> EcatChain:
    """``chain`` with the mailboxes of :data:`MAILBOXES` configured and released by each ESC's
    PDI (which deactivates every SyncManager at power-on, datasheet I 8.7)."""
    chain.process_frame(bwr(0x0810, MAILBOXES))
    for dev in chain.devices:
        dev.pdi_deactivate_sms((2, 3), False)
    return chain


def fill_mailboxes(chain: EcatChain, rng: random.Random) -> None:
    """The PDI fills the read mailbox at some ESCs and empties the write mailbox at others
    (datasheet I 8.2: a full read mailbox and an empty write mailbox are ECAT's to access)."""
    for dev in chain.devices:
        what = rng.random()
        if what < 0.3:
            dev.pdi_write(0x7000, rng.randbytes(16))
        elif what < 0.6:
            dev.pdi_read(0x7100, 16)


def test_idle_mailboxes_are_holes_over_the_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    """Logical datagrams through FMMUs onto a read and a write mailbox, which the PDI now and
    then fills and empties at some ESCs: over the rows where a mailbox is idle (an empty read
    mailbox, a full write mailbox: the access does nothing there, datasheet I 8.2.1), by the
    ESC where it is not, and the same bytes, memory and event requests as ESC by ESC."""
    taken = {"idle": 0, "busy": 0}
    mailboxes_idle = EscDevice._mailboxes_idle

    def counted(self: EscDevice, mailboxes: mapping.Mailboxes) -> bool:
        idle = mailboxes_idle(self, mailboxes)
        taken["idle" if idle else "busy"] += 1
        return idle

    monkeypatch.setattr(EscDevice, "_mailboxes_idle", counted)
    fast, reference = with_mailboxes(line(EcatChain)), with_mailboxes(line(OneByOne))
    rng = random.Random(21)
    for i in range(1_200):
        if i % 10 == 0:
            seed = rng.randrange(1 << 30)
            fill_mailboxes(fast, random.Random(seed))
            fill_mailboxes(reference, random.Random(seed))
        if rng.random() < 0.2:
            data = bwr(0x0600 + 16 * rng.randrange(4), mailbox_fmmu(rng))
        else:
            data = frame(rng)
        assert_same(fast, reference, data, f"frame {i}")
    assert taken["idle"] > 100 and taken["busy"] > 100, taken


def test_an_lrd_reads_a_read_mailbox_only_when_it_is_full() -> None:
    """Hand-worked: FMMU 1 of 12 ESCs reads logical 0x8000 + 4 from 0x6FFE, the last 2 bytes
    of user RAM before the read mailbox and its first 2. With every mailbox empty, the LRD
    reads the RAM bytes (00) and leaves the mailbox's frame bytes as sent (EE EE), the 11
    ESCs whose process RAM is open counting for the RAM; once ESC 7's PDI writes its mailbox
    (A0 + k), ESC 7 reads A0 A1 there, which the ESCs after it leave, and its status register
    shows the buffer open (0x0815 bit 6, datasheet II 2.14.5, until the frame that reads the
    end address)."""
    chains = [with_mailboxes(line(kind)) for kind in (EcatChain, OneByOne)]
    for chain in chains:
        chain.process_frame(bwr(0x0610, read_fmmu(0x8000, 0x6FFE, 4)))
    frame_ = ethercat.frame(
        EcatFrame((Datagram.logical(Command.LRD, 0x8000, b"\xee" * 4),))
    ).to_bytes()
    for chain in chains:
        back = chain.process_frame(frame_)
        assert back is not None
        (d,) = ethercat.decode(back[14:])[0].datagrams
        assert (d.data, d.wkc) == (b"\x00\x00\xee\xee", NODES - 1)
        chain.devices[7].pdi_write(0x7000, bytes(range(0xA0, 0xB0)))
        back = chain.process_frame(frame_)
        assert back is not None
        (d,) = ethercat.decode(back[14:])[0].datagrams
        assert (d.data, d.wkc) == (b"\x00\x00\xa0\xa1", NODES - 1)
        assert chain.devices[7].registers(0x0815, 1)[0] & 0x40
        assert not chain.devices[6].registers(0x0815, 1)[0] & 0x40


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_syncmanagers_that_all_start_anew_are_new_when_first_used(kind: type[EcatChain]) -> None:
    """Hand-worked: one frame disables every SyncManager of 12 ESCs, the next enables the two
    mailboxes of :data:`MAILBOXES` again, the write mailbox moved to 0x7200. Each SyncManager
    starts anew (the ESCs make them when first used: nothing may see the ones before), with no
    buffer: status 0x30 (datasheet II 2.14.5), and ESC 2's PDI had locked the write mailbox
    before (0x081F bit 0, which ECAT does not write): it stays locked. ESC 0's PDI reads the
    moved write mailbox while it is empty: the read interrupt (bit 1) is set, 0x32. An LWR of
    16 bytes through FMMU 2 onto 0x7200 then writes the empty write mailbox of every ESC but
    ESC 2 (it is not idle: only a full one is), opening it (write open 0x80 set, read interrupt
    cleared: 0x30 or 0x32 -> 0xB0) and, with its last byte, filling it at the frame's end (open
    cleared, write interrupt 0x01 and mailbox full 0x08 set: 0x39); the PDI of ESC 3 reads the
    message back (0x39 -> 0x32)."""
    chain = with_mailboxes(line(kind))
    chain.devices[2].pdi_deactivate_sms((3,), True)
    count = chain.devices[0].config.syncmanagers
    chain.process_frame(bwr(0x0800, bytes(SM_BYTES * count)))
    moved = MAILBOXES[:8] + struct.pack("<HHBBBB", 0x7200, 16, 0x06, 0, 0x01, 0)
    chain.process_frame(bwr(0x0810, moved))
    status = 0x0805 + SM_BYTES * 3
    assert [dev.registers(status, 1)[0] for dev in chain.devices] == [0x30] * NODES
    assert chain.devices[0].pdi_read(0x7200, 16) == bytes(16)
    assert chain.devices[0].registers(status, 1)[0] == 0x32
    chain.process_frame(bwr(0x0620, write_fmmu(0x9000, 0x7200, 16)))
    message = bytes(range(0x50, 0x60))
    assert logical(chain, Command.LWR, 0x9000, message).wkc == NODES - 1
    assert [dev.registers(status, 1)[0] for dev in chain.devices] == [0x39] * 2 + [0x30] + [
        0x39
    ] * (NODES - 3)
    assert chain.devices[3].pdi_read(0x7200, 16) == message
    assert chain.devices[3].registers(status, 1)[0] == 0x32


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_a_syncmanager_kept_through_changes_keeps_its_mail_and_one_enabled_again_is_empty(
    kind: type[EcatChain],
) -> None:
    """Hand-worked: FMMU 2 maps logical 0x9000 + 16 onto the write mailbox (0x7100, of
    :data:`MAILBOXES`), and an LWR fills it at all 12 ESCs (working counter 12). Three frames
    then change the SyncManager table while no frame touches the mailboxes: the write mailbox
    is disabled (0x081E = 0), enabled again (it starts anew, empty: datasheet I 8.1, II 2.14.1)
    and SyncManager 4 is enabled (0x0826 = 1; the write mailbox is kept: same area, enabled
    before the frame). The read mailbox (0x7000) is kept by all three. The same LWR then fills
    the empty write mailbox again (12), its status 0x39 (no buffer written 0x30, write
    interrupt, full; II 2.14.5); had an ESC taken its old, full one back, the LWR would find it
    full and write nothing there. The PDI of ESC 0 put a message in the read mailbox before the
    changes; an LRD through FMMU 3 (0xA000 + 16) still reads it there (working counter 1)."""
    chain = with_mailboxes(line(kind))
    chain.process_frame(bwr(0x0620, write_fmmu(0x9000, 0x7100, 16) + read_fmmu(0xA000, 0x7000, 16)))
    message = bytes(range(0x40, 0x50))
    assert logical(chain, Command.LWR, 0x9000, bytes(16)).wkc == NODES
    chain.devices[0].pdi_write(0x7000, message)
    for ado, data in ((0x081E, b"\x00"), (0x081E, b"\x01")):
        chain.process_frame(bwr(ado, data))
    chain.process_frame(bwr(0x0820, struct.pack("<HHBBBB", 0x7800, 8, 0x00, 0, 0x01, 0)))
    assert logical(chain, Command.LWR, 0x9000, message).wkc == NODES
    status = 0x0805 + SM_BYTES * 3
    assert [dev.registers(status, 1)[0] for dev in chain.devices] == [0x39] * NODES
    assert chain.devices[1].pdi_read(0x7100, 16) == message
    read = lrd(chain, 0xA000, 16)
    assert (read.data, read.wkc) == (message, 1)


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_a_write_that_starts_inside_a_syncmanager_waiting_to_be_made_meets_it(
    kind: type[EcatChain],
) -> None:
    """Hand-worked: SyncManager 4 enabled (0x0826 = 1) leaves the mailboxes of
    :data:`MAILBOXES` kept, and the ESC makes its SyncManagers only once it needs them. An
    FPWR of 4 bytes at 0x710E to ESC 0 (station address 0x1001) starts inside the write
    mailbox (0x7100 + 16), not at its start: those 2 bytes are refused (datasheet I 8.2.1, "a
    buffer has to be accessed beginning with the start address"), and the 2 beyond its end,
    plain process RAM, are written (working counter 1)."""
    chain = with_mailboxes(line(kind))
    chain.process_frame(bwr(0x0820, struct.pack("<HHBBBB", 0x7800, 8, 0x00, 0, 0x01, 0)))
    assert sent(chain, Datagram(Command.FPWR, 0x1001, 0x710E, bytes.fromhex("aabbccdd"))).wkc == 1
    assert bytes(chain.memory[0, 0x710C:0x7114]).hex() == "00000000ccdd0000"


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_a_read_write_of_al_status_writes_it_into_process_ram_where_it_is_open(
    kind: type[EcatChain],
) -> None:
    """Hand-worked: the read/write offset (0x0108) is 0x2ED0 at every ESC, so a BRW of AL status
    (0x0130, 2 bytes, data 0x0040) reads it and writes 0x3000, process RAM (datasheet I Table
    7: read before write, the write takes the data as it arrived). ESC 0 writes 0x0040 and
    leaves 0x0048 (its state OP, 8); ESCs 1-4 write 0x0048; ESC 5, whose EEPROM did not load,
    reads INIT (1) but has no process RAM to write (I 11.2.1); ESCs 6-11 write 0x0049, which
    the frame brings back. Working counter: 12 reads + 2 x 11 writes = 34."""
    chain = line(kind)
    chain.process_frame(bwr(0x0108, struct.pack("<H", 0x3000 - 0x0130)))
    got = sent(chain, Datagram(Command.BRW, 0, 0x0130, b"\x40\x00"))
    assert (got.data, got.wkc) == (b"\x49\x00", 34)
    assert [bytes(chain.memory[p, 0x3000:0x3002]) for p in range(NODES)] == [b"\x40\x00"] + [
        b"\x48\x00"
    ] * 4 + [bytes(2)] + [b"\x49\x00"] * 6


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
@pytest.mark.parametrize("cmd", [Command.BRD, Command.BWR, Command.BRW, Command.ARMW, Command.FRMW])
@pytest.mark.parametrize("ado", [0x0F80, 0x1000, 0x1200, 0xFFFF])
def test_a_broadcast_of_no_bytes_beyond_the_registers_does_nothing(
    kind: type[EcatChain], cmd: Command, ado: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A broadcast, ARMW or FRMW of no bytes at user RAM, the input buffer (0x1000), the write
    buffer (0x1200) or the last byte reads and writes no byte: working counter 0 and memory
    as it was, at every ESC; the chain asks none of them on its own."""
    chain = line(kind)
    if cmd == Command.BRW:  # its write at the read/write offset: 0x0F80 on at every ESC
        chain.process_frame(bwr(0x0108, struct.pack("<H", (0x1000 - ado) & 0xFFFF)))
    before = chain.memory.copy()
    alone = on_their_own(monkeypatch)
    adp = 0x1001 if cmd == Command.FRMW else 0
    got = sent(chain, Datagram(cmd, adp, ado, b""))
    assert got.wkc == 0
    assert np.array_equal(chain.memory, before)
    assert (alone == []) == (kind is EcatChain)


@pytest.mark.parametrize("cmd", [Command.BWR, Command.BRD])
@pytest.mark.parametrize(
    ("ado", "n"),
    [
        (0x0F70, 0x20),  # registers, then user RAM
        (0x0E00, 0x190),  # into user RAM, up to the input buffer
        (0x0F7F, 0x90),  # into the input buffer, which a BWR does not write
        (0x0EF0, 0x400),  # and the write buffer at 0x1200
        (0x09F0, 0x5A0),  # from DC registers, which a BRD reads at the frame's time
    ],
)
def test_a_broadcast_from_registers_into_ram_leaves_the_same_bytes(
    cmd: Command, ado: int, n: int
) -> None:
    """A BWR or BRD from registers into user and process RAM: the same returned frame, memory
    and event requests as every ESC in turn, the DL and AL status events raised first. (One
    frame cannot hold such a datagram from the reset register, 0x0040, on: 3,904 bytes.)"""
    fast, reference = line(EcatChain), line(OneByOne)
    for chain in (fast, reference):
        raise_events(chain)
    data = bytes(range(1, 256)) * (n // 255 + 1)
    dg = Datagram(cmd, 0, ado, data[:n])
    assert_same(fast, reference, ethercat.frame(EcatFrame((dg,))).to_bytes(), f"{cmd} {ado:#x}")


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_a_read_write_of_no_bytes_writes_registers_at_its_offset(kind: type[EcatChain]) -> None:
    """Hand-worked: the read/write offset is 0xF000 at ESC 2 and 0 elsewhere. A BRW of no bytes
    at 0x1000 reads nothing, but ESC 2 writes at 0x0000, a register: a write that counts 2
    (datasheet I Table 7: the write's count is 2), though it writes no byte."""
    chain = line(kind)
    sent(chain, Datagram(Command.APWR, -2 & 0xFFFF, 0x0108, struct.pack("<H", 0xF000)))
    assert sent(chain, Datagram(Command.BRW, 0, 0x1000, b"")).wkc == 2


def dividers_line(kind: type[EcatChain]) -> EcatChain:
    """:func:`line` with the watchdog divider (0x0400) 0 at every ESC but ESC 1, 0x4000."""
    chain = line(kind)
    chain.process_frame(bwr(0x0400, bytes(2)))
    sent(chain, Datagram(Command.APWR, -1 & 0xFFFF, 0x0400, b"\x00\x40"))
    return chain


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_a_read_write_of_registers_writes_at_each_escs_own_offset(
    kind: type[EcatChain], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Hand-worked: the read/write offset (0x0108) is 0x0010 at ESC 3 and 0 elsewhere; the
    watchdog divider (0x0400) is 0 but at ESC 1, 0x4000. A BRW of 0x0400, data 0x1234: each ESC
    writes the data as it arrives (datasheet I Table 7) at 0x0400 plus its offset, then ORs its
    divider in. ESCs 0 and 1 write 0x1234, ESC 1 leaves 0x5234, ESC 3 writes it into its PDI
    watchdog (0x0410) and keeps its divider 0, the others write 0x5234; the frame brings
    0x5234 back. Working counter: 12 reads + 2 x 12 writes = 36. The chain does it over the
    rows: no ESC on its own."""
    chain = dividers_line(kind)
    sent(chain, Datagram(Command.APWR, -3 & 0xFFFF, 0x0108, b"\x10\x00"))
    alone = on_their_own(monkeypatch)
    got = sent(chain, Datagram(Command.BRW, 0, 0x0400, b"\x34\x12"))
    assert (got.data, got.wkc) == (b"\x34\x52", 36)
    dividers = [bytes(chain.memory[p, 0x0400:0x0402]) for p in range(NODES)]
    assert dividers == [b"\x34\x12"] * 2 + [b"\x34\x52", bytes(2)] + [b"\x34\x52"] * 8
    assert bytes(chain.memory[3, 0x0410:0x0412]) == b"\x34\x52"
    assert (alone == []) == (kind is EcatChain)


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_a_read_write_of_registers_writes_into_ram_where_an_escs_offset_puts_it(
    kind: type[EcatChain], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Hand-worked: as above (the watchdog divider 0 but 0x4000 at ESC 1; BRW of 0x0400, data
    0x1234), with the read/write offsets 0x1400 at ESCs 3 and 5 (a write at 0x1800, process
    RAM), 0 elsewhere. ESC 3 writes 0x5234 into its process RAM at once; ESC 5, whose EEPROM
    did not load, has no process RAM (datasheet I 11.2.1): its write counts nothing. The
    others write their divider as before. Working counter: 12 reads + 2 x 11 writes = 34. Only
    ESCs 3 and 5 write on their own."""
    chain = dividers_line(kind)
    for p in (3, 5):
        sent(chain, Datagram(Command.APWR, -p & 0xFFFF, 0x0108, struct.pack("<H", 0x1400)))
    alone = on_their_own(monkeypatch)
    got = sent(chain, Datagram(Command.BRW, 0, 0x0400, b"\x34\x12"))
    assert (got.data, got.wkc) == (b"\x34\x52", 34)
    dividers = [bytes(chain.memory[p, 0x0400:0x0402]) for p in range(NODES)]
    assert (
        dividers
        == [b"\x34\x12"] * 2 + [b"\x34\x52", bytes(2), b"\x34\x52", bytes(2)] + [b"\x34\x52"] * 6
    )
    assert [bytes(chain.memory[p, 0x1800:0x1802]) for p in (3, 5)] == [b"\x34\x52", bytes(2)]
    assert sorted(alone) == ([3, 5] if kind is EcatChain else list(range(NODES)))


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_a_read_write_of_registers_writes_into_user_ram_at_one_offset(
    kind: type[EcatChain],
) -> None:
    """Hand-worked: as above (the watchdog divider 0 but 0x4000 at ESC 1; BRW of 0x0400, data
    0x1234), with the read/write offset 0x0B80 at every ESC: each writes at 0x0F80, user RAM,
    at once, the data as it arrives (datasheet I Table 7): ESCs 0 and 1 write 0x1234, the
    others 0x5234, which the frame brings back; no divider changes, and ESC 5, whose EEPROM
    did not load, writes too (user RAM is not process RAM, I 11.2.1). Working counter: 12
    reads + 2 x 12 writes = 36."""
    chain = dividers_line(kind)
    chain.process_frame(bwr(0x0108, struct.pack("<H", 0x0B80)))
    got = sent(chain, Datagram(Command.BRW, 0, 0x0400, b"\x34\x12"))
    assert (got.data, got.wkc) == (b"\x34\x52", 36)
    dividers = [bytes(chain.memory[p, 0x0400:0x0402]) for p in range(NODES)]
    assert dividers == [bytes(2), b"\x00\x40"] + [bytes(2)] * 10
    written = [bytes(chain.memory[p, 0x0F80:0x0F82]) for p in range(NODES)]
    assert written == [b"\x34\x12"] * 2 + [b"\x34\x52"] * 10


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_a_read_multiple_write_of_process_ram_writes_what_the_addressed_esc_read(
    kind: type[EcatChain],
) -> None:
    """Hand-worked: ESC 3's PDI put 0x3412 at 0x3000 (process RAM). An FRMW of 2 bytes there,
    data 0xBBAA, addressed to ESC 3 (station address 0x1004): ESCs 0-2 write 0xBBAA, ESC 3
    reads 0x3412 into the frame, the ESCs after it write 0x3412 (datasheet I Table 7) but ESC
    5, whose EEPROM did not load (no process RAM, I 11.2.1); the frame brings 0x3412 back.
    Working counter: 10 writes and the read, 11."""
    chain = line(kind)
    chain.devices[3].pdi_write(0x3000, b"\x12\x34")
    got = sent(chain, Datagram(Command.FRMW, 0x1004, 0x3000, b"\xaa\xbb"))
    assert (got.data, got.wkc) == (b"\x12\x34", 11)
    assert [bytes(chain.memory[p, 0x3000:0x3002]) for p in range(NODES)] == [b"\xaa\xbb"] * 3 + [
        b"\x12\x34"
    ] * 2 + [bytes(2)] + [b"\x12\x34"] * 6


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_an_esc_whose_process_ram_is_closed_does_not_share_its_neighbours_access(
    kind: type[EcatChain],
) -> None:
    """Hand-worked: 12 ESCs with one FMMU table (FMMU 0 writes logical 0x9000 + 16 to 0x3000,
    the others off) and no SyncManager, so that an access is worked out alike at each; but ESC
    5's EEPROM checksum is wrong, so its PDI never starts and ECAT has no process RAM there
    (datasheet I 11.2.1). An LWR of 16 bytes writes 0x3000 at the other 11 (working counter
    11) and leaves ESC 5's zeros."""
    chain = line(kind)
    config = chain.devices[0].config
    chain.process_frame(bwr(0x0800, bytes(SM_BYTES * config.syncmanagers)))
    table = write_fmmu(0x9000, 0x3000, 16) + bytes(16 * (config.fmmus - 1))
    chain.process_frame(bwr(0x0600, table))
    data = bytes(range(0x60, 0x70))
    assert logical(chain, Command.LWR, 0x9000, data).wkc == NODES - 1
    assert [bytes(chain.memory[p, 0x3000:0x3010]) for p in range(NODES)] == [data] * CLOSED + [
        bytes(16)
    ] + [data] * (NODES - CLOSED - 1)


def sync0_line(kind: type[EcatChain], now: list[int]) -> EcatChain:
    """12 patches whose SYNC0 fired at 5 ms of system time (datasheet II 2.22: SOEM's order of
    writes; clocks retuned to start at 0, host time ``now[0]``)."""
    chain = kind.configured(NODES, SIZE)
    chain.clock_ns = lambda: now[0]
    for dev in chain.devices:
        dev.dc.retune(0.0, 0)
    for ado, data in (
        (0x0981, b"\x00"),
        (0x0990, struct.pack("<Q", 5_000_000)),
        (0x09A0, struct.pack("<I", 1_000_000)),
        (0x0981, b"\x03"),
    ):
        chain.process_frame(bwr(ado, data))
    return chain


@pytest.mark.parametrize("parts", [1, 2])
def test_reads_of_dc_registers_see_them_at_the_frames_time(
    parts: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Hand-worked: FMMU 1 of 12 ESCs reads the SYNC0 status (0x098E, 1 byte) into logical
    0x9000 and, with ``parts`` = 2, FMMU 2 reads the activation status (0x0984) into 0x9001.
    SYNC0 fired at 5 ms: an LRD at 5.3 ms reads status 1 (from the last ESC back), and the
    read clears it, so the next LRD reads 0; the activation status is 0 (activated). With one
    part the chain brings every ESC's DC registers up to the frame's time and reads them over
    the rows (12 refreshes); with two, the refresh for the second part would clear the status
    the first reads (it writes 0x098E again), so each ESC reads in its own order, as ESC by
    ESC."""
    refreshed: list[int] = []
    refresh = EscDevice._refresh_dc

    def counted(self: EscDevice, registers: tuple[tuple[int, int], ...]) -> None:
        refreshed.append(self.position)
        refresh(self, registers)

    monkeypatch.setattr(EscDevice, "_refresh_dc", counted)
    now = [0]
    chains = [sync0_line(kind, now) for kind in (EcatChain, OneByOne)]
    fmmus = [(0x0610, read_fmmu(0x9000, 0x098E, 1)), (0x0620, read_fmmu(0x9001, 0x0984, 1))]
    for chain in chains:
        for at, table in fmmus[:parts]:
            chain.process_frame(bwr(at, table))
    now[0] = 5_300_000
    expected = [b"\x01\x00"[:parts], b"\x00\x00"[:parts]]
    for k, data in enumerate(expected):
        backs = [lrd(chain, 0x9000, parts) for chain in chains]
        assert backs[0] == backs[1], k
        assert (backs[0].data, backs[0].wkc) == (data, NODES), k
    assert len(refreshed) == (2 * NODES if parts == 1 else 0)


def shadow_writes(
    registers: bytes, parts: Sequence[mapping.LogicalOp], data_in: bytes
) -> list[tuple[int, bytes]]:
    """An oracle from datasheet I 3.4, ESC by ESC in integers: what write parts of a datagram
    whose data arrived as ``data_in`` put among an ESC's shadow writes, ``registers`` its
    memory: the bytes each writes below 0x0F80, a bit-wise part's merged with the registers
    as committed."""
    out = []
    for op in parts:
        keep = min(op.size, 0x0F80 - op.phys)
        if op.bytewise:
            out.append((op.phys, data_in[op.at : op.at + keep]))
            continue
        value = int.from_bytes(data_in[op.at : op.at + op.width], "little")
        value = value << op.shift if op.shift >= 0 else value >> -op.shift
        old = int.from_bytes(registers[op.phys : op.phys + op.size], "little")
        merged = ((old & ~op.mask) | (value & op.mask)).to_bytes(op.size, "little")
        out.append((op.phys, merged[:keep]))
    return out


def test_shadow_writes_take_the_register_bytes_alone() -> None:
    """Hand-worked: what write parts put among an ESC's shadow writes (datasheet I 3.4) is the
    bytes they write below 0x0F80 (the RAM after it is written at once). A byte-wise part of
    8 bytes at 0x0F7C from frame byte 1 (data 00 01 02 ...): 01 02 03 04 at 0x0F7C. A bit-wise
    part of physical bytes 0x0F7E-0x0F81 (holding 11 22 33 44), frame bytes 2-4 (02 03 04,
    0x040302) shifted 4 bits up (0x403020), under the physical mask 0x0FF00FF0 (0x00400020),
    over the bits kept (0x44332211 & 0xF00FF00F = 0x40032001): 0x40432021, of which the
    registers 0x0F7E-0x0F7F take 21 20; over the rows of one ESC and by the oracle alike."""
    chain = line(EcatChain)
    dev = chain.devices[0]
    dev.pdi_write(0x0F7E, b"\x11\x22\x33\x44")
    parts = (
        mapping.byte_op(0x0F7C, 1, 8),
        mapping.LogicalOp(False, 0x0F7E, 4, 4, 0x0FF0_0FF0, 2, 3),
    )
    expected = [(0x0F7C, b"\x01\x02\x03\x04"), (0x0F7E, b"\x21\x20")]
    arrived = np.frombuffer(bytes(range(16)), np.uint8)[None, :]
    dev.pending.clear()
    together._shadow_rows(chain.memory, slice(0, 1), parts, (False, False), arrived, arrived, [dev])
    assert dev.pending == expected
    assert shadow_writes(dev.mem, parts, bytes(range(16))) == expected


def test_shadow_writes_over_the_rows_are_each_escs() -> None:
    """The shadow writes of write parts over the rows (logical_together) are those the oracle
    works out for each ESC (:func:`shadow_writes`), whatever each ESC's registers hold, from
    data that arrived alike or differently at each."""
    chain = line(EcatChain)
    rng = random.Random(3)
    devices = chain.devices
    for dev in devices:
        dev.pending.clear()
    for _ in range(200):
        for dev in devices:
            dev.pdi_write(0x0F70, rng.randbytes(16))
        phys = rng.choice((0x0F70, 0x0F7C, 0x0F7F))
        width, at = rng.randrange(1, 6), rng.randrange(4)
        part = mapping.LogicalOp(
            False, phys, width, rng.randrange(-12, 12), rng.getrandbits(8 * width), at, 3
        )
        if rng.random() < 0.3:
            part = mapping.byte_op(phys, at, width)
        arrived = np.frombuffer(rng.randbytes(8), np.uint8)[None, :]
        data_in = np.frombuffer(rng.randbytes(8 * NODES), np.uint8).reshape(NODES, 8)
        varies = rng.random() < 0.5
        together._shadow_rows(
            chain.memory, slice(0, NODES), (part,), (varies,), arrived, data_in, devices
        )
        for p, dev in enumerate(devices):
            data = (data_in[p] if varies else arrived[0]).tobytes()
            assert dev.pending == shadow_writes(dev.mem, (part,), data), (p, part)
            dev.pending.clear()


@pytest.mark.parametrize("least", [1, together.LOGICAL_TOGETHER_MIN])
def test_escs_with_one_cut_and_other_register_writes_are_apart(
    least: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Hand-worked: 12 ESCs whose FMMU 1 maps logical 0xB000 + 16, byte-wise, for writing onto
    FMMU 3's registers (0x0630). The last ESC has 8 FMMUs, so the write goes to its shadow
    registers and takes effect; the others have 3, so those bytes are reserved and the write
    changes nothing, though it counts (datasheet II 2.13). Every ESC's plan cut is the same (a
    write of no byte at 0x0630, for the working counter), yet only the last ESC writes
    registers: after an LWR of an FMMU entry there, it holds the entry and the others hold
    zeros, as ESC by ESC, with the working counter 12. (With ``least`` = 1 every run of ESCs
    goes over the rows.)"""
    monkeypatch.setattr("emulator.esc.chain.LOGICAL_TOGETHER_MIN", least)
    chains = []
    for kind in (EcatChain, OneByOne):
        devices = [
            EscDevice(
                SlaveInfo.skin_patch(SIZE, serial=p + 1),
                config=EscConfig(fmmus=8 if p == NODES - 1 else 3),
            )
            for p in range(NODES)
        ]
        chain = kind(devices)
        for frame_ in configure_frames(devices[0].info, NODES):
            chain.process_frame(frame_)
        chain.process_frame(
            bwr(0x0610, struct.pack("<IHBBHBBB3x", 0xB000, 16, 0, 7, 0x0630, 0, 2, 1))
        )
        chains.append(chain)
    entry = struct.pack("<IHBBHBBB3x", 0xC000, 4, 0, 7, 0x1800, 0, 1, 1)
    lwr = ethercat.frame(EcatFrame((Datagram.logical(Command.LWR, 0xB000, entry),))).to_bytes()
    back = chains[0].process_frame(lwr)
    assert back == chains[1].process_frame(lwr)
    assert back is not None and ethercat.decode(back[14:])[0].datagrams[0].wkc == NODES
    assert np.array_equal(chains[0].memory, chains[1].memory)
    memory = chains[0].memory
    assert memory[-1, 0x0630:0x0640].tobytes() == entry
    assert not memory[:-1, 0x0630:0x0640].any()


def test_broadcasts_of_memory_leave_the_same_bytes() -> None:
    """BWRs, BRDs and BRWs of user and process RAM (with read/write offsets 0x0108 set at one
    ESC or all), at ESCs whose SyncManager areas they miss and at ESCs with areas of their own
    (the input buffer at 0x1000 + 8, the write buffer at 0x1200 + 16, locked at some ESCs, and
    a write buffer at 0x8000 + 16 at every fifth ESC), at one ESC whose EEPROM did not load (no
    process RAM), up to the end of the address space: the same returned frame, memory and
    event requests as every ESC in turn, frame after frame."""
    fast, reference = line(EcatChain), line(OneByOne)
    rng = random.Random(8)
    starts = (0x0F80, 0x0FF8, 0x0FFE, 0x1004, 0x11F8, 0x1210, 0x1300, 0x8000, 0xFFF0, 0xFFFE)
    for chain in (fast, reference):
        for at in (0x0FF0, 0x1300, 0x8000, 0xFFE0):  # what ECAT must not see at CLOSED
            chain.devices[CLOSED].pdi_write(at, bytes(range(0xA0, 0xC0)))
        for p in range(0, NODES, 5):  # SyncManager 2 a buffer ECAT writes at 0x8000 + 16 here
            sm2 = struct.pack("<HHBBBB", 0x8000, 16, 0x04, 0, 0x01, 0)
            chain.process_frame(
                ethercat.frame(
                    EcatFrame((Datagram(Command.APWR, -p & 0xFFFF, 0x0810, sm2),))
                ).to_bytes()
            )
            chain.devices[p].pdi_deactivate_sms((2,), False)
    for i in range(1_000):
        dgs = []
        if rng.random() < 0.1:  # the read/write offset (datasheet II 2.4), at one ESC or all
            # (0xF300 takes a BRW's write back into registers from 0x0280 on: not DL control,
            # whose loops would close)
            offset = struct.pack("<H", rng.choice((0, 0x10, 0x400, 0x7000, 0xF300)))
            one = rng.random() < 0.3
            cmd, adp = (Command.APWR, -rng.randrange(NODES) & 0xFFFF) if one else (Command.BWR, 0)
            dgs.append(Datagram(cmd, adp, 0x0108, offset))
        for _ in range(rng.randint(1, 3)):
            ado = rng.choice(starts) + rng.randrange(-1, 2) if rng.random() < 0.8 else 0
            ado = ado or rng.randrange(0x0F80, 0x10000)  # user and process RAM
            data = rng.randbytes(rng.randrange(1, 64))
            cmd = rng.choice((Command.BWR, Command.BRD, Command.BRW, Command.APWR))
            adp = -rng.randrange(NODES) & 0xFFFF if cmd == Command.APWR else 0
            dgs.append(Datagram(cmd, adp, ado, data))
        assert_same(fast, reference, ethercat.frame(EcatFrame(tuple(dgs))).to_bytes(), str(i))
    assert all(dev.onward for dev in fast.devices[:-1])  # every frame went down the line
    # a buffer the PDI locked, and every SyncManager disabled (one ESC without process RAM)
    fast, reference = line(EcatChain), line(OneByOne)
    for chain in (fast, reference):
        for dev in chain.devices:
            dev.pdi_deactivate_sms((0,), True)
    for cmd in (Command.BRD, Command.BWR, Command.BRW):
        dg = Datagram(cmd, 0, 0x0FFC, bytes(range(1, 13)))  # over the input buffer 0x1000 + 8
        assert_same(fast, reference, ethercat.frame(EcatFrame((dg,))).to_bytes(), str(cmd))
    fast, reference = line(EcatChain), line(OneByOne)
    assert_same(fast, reference, bwr(0x0800, bytes(64)), "SyncManagers off")
    for cmd in (Command.BRD, Command.BWR, Command.BRW):
        dg = Datagram(cmd, 0, 0x0FF0, bytes(range(1, 33)))  # user RAM, then process RAM
        assert_same(fast, reference, ethercat.frame(EcatFrame((dg,))).to_bytes(), str(cmd))


def test_broadcast_reads_of_dc_registers_see_them_at_the_frames_time() -> None:
    """BRDs and BRWs of DC registers (0x0900 on: receive times, system time, SYNC status
    and times) at 12 ESCs whose SYNC0 fires every ms from 5 ms, over the rows after each ESC
    brought them up to the frame's time, frame after frame as time goes on: the same bytes,
    memory and event requests as every ESC in turn (whose reads of the SYNC0 status clear
    it). Hand-worked at 5.3 ms: a BRD of the SYNC0 status (0x098E) reads 1, the next 0."""
    now = [0]
    fast, reference = (sync0_line(kind, now) for kind in (EcatChain, OneByOne))
    now[0] = 5_300_000  # the first pulse (5 ms) fired
    brd = ethercat.frame(EcatFrame((Datagram(Command.BRD, 0, 0x098E, b"\x00"),))).to_bytes()
    for want in (b"\x01", b"\x00"):
        back = fast.process_frame(brd)
        assert back == reference.process_frame(brd) and back is not None
        assert ethercat.decode(back[14:])[0].datagrams[0].data == want
    rng = random.Random(4)
    for i in range(300):  # (BRWs write DC registers too: SYNC0 may stop, or start again)
        now[0] = 5_400_000 + 37_000 * i
        ado = rng.choice((0x0900, 0x0910, 0x0980, 0x0984, 0x098E, 0x0990, 0x09A0))
        cmd = rng.choice((Command.BRD, Command.BRD, Command.BRW))
        data = rng.randbytes(rng.randrange(1, 0x20)) if cmd == Command.BRW else bytes(8)
        dg = Datagram(cmd, 0, ado, data)
        assert_same(fast, reference, ethercat.frame(EcatFrame((dg,))).to_bytes(), str(i))


def one_station(kind: type[EcatChain]) -> EcatChain:
    """:func:`line` after a broadcast gave every ESC station address 0x4242, as a hostile write
    of 0x0010 does, with the DL and AL status events pending (:func:`raise_events`)."""
    chain = line(kind)
    chain.process_frame(bwr(0x0010, b"\x42\x42"))
    raise_events(chain)
    return chain


@pytest.mark.parametrize("cmd", [Command.FPRD, Command.FPWR, Command.FPRW])
@pytest.mark.parametrize(
    ("ado", "n", "offsets"),
    [
        (0x0120, 2, None),  # AL control: a write that waits for the end of the frame
        (0x0130, 6, None),  # AL status, whose read clears its event
        (0x0100, 0x20, None),  # DL control and status (the read clears DL status event)
        (0x0040, 1, None),  # the reset register: each ESC writes it on its own
        (0x0400, 2, 0x0010),  # the watchdog divider, written at 0x0410 by an FPRW
        (0x0400, 2, 0xF000),  # an FPRW's write into process RAM at 0xF400 (not at CLOSED)
        (0x0400, 2, 0x0C00),  # into the input buffer (0x1000), which ECAT does not write
        (0x0400, 2, 0x0E00),  # into the buffer ECAT writes (0x1200): each ESC's
        (0x0F70, 2, 0x0010),  # registers, an FPRW writing them into user RAM at 0x0F80
        (0x0F70, 0x20, None),  # registers and user RAM: each ESC's
        (0x0900, 8, None),  # DC receive times, which run with the clock: each ESC reads
        (0x0300, 0, None),  # no byte, at a register: counts
    ],
)
def test_a_configured_address_datagram_at_many_escs_leaves_the_same_bytes(
    cmd: Command,
    ado: int,
    n: int,
    offsets: int | None,
) -> None:
    """Every ESC has station address 0x4242: an FPRD, FPWR or FPRW addressed to it leaves the
    same returned frame, memory and event requests as every ESC in turn, also an FPRW whose
    write the read/write offset (``offsets``, 0x0108 at every ESC) puts elsewhere."""
    fast, reference = one_station(EcatChain), one_station(OneByOne)
    if offsets is not None:
        for chain in (fast, reference):
            chain.process_frame(bwr(0x0108, struct.pack("<H", offsets)))
    dg = Datagram(cmd, 0x4242, ado, bytes(range(7, 7 + n)))
    assert_same(fast, reference, ethercat.frame(EcatFrame((dg,))).to_bytes(), f"{cmd} {ado:#x}")


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_an_fprw_at_many_escs_writes_what_the_esc_before_read(kind: type[EcatChain]) -> None:
    """Hand-worked: every ESC has station address 0x4242 but ESC 4; the watchdog divider
    (0x0400) is 0 but at ESC 1, 0x4000 (:func:`dividers_line`). An FPRW of 0x0400 with data
    0x1234: each addressed ESC replaces the data with its divider (datasheet I Table 7) and
    writes the data as it arrived, the ESC before it's divider: ESC 0 writes 0x1234, ESC 2 (after
    ESC 1) 0x4000, the others 0; the frame brings back the last one's, 0. Working counter:
    11 x 3 = 33."""
    chain = dividers_line(kind)
    chain.process_frame(bwr(0x0010, b"\x42\x42"))
    sent(chain, Datagram(Command.APWR, -4 & 0xFFFF, 0x0010, b"\x01\x00"))
    got = sent(chain, Datagram(Command.FPRW, 0x4242, 0x0400, b"\x34\x12"))
    assert (got.data, got.wkc) == (bytes(2), 33)
    dividers = [bytes(chain.memory[p, 0x0400:0x0402]) for p in range(NODES)]
    assert dividers == [b"\x34\x12", bytes(2), b"\x00\x40"] + [bytes(2)] * 9


@pytest.mark.parametrize(
    ("made", "record"),
    [
        (mapping._op, mapping.LogicalOp),
        (mapping._part_holes, mapping.PartHoles),
        (mapping._plain_access, mapping.PlainAccess),
        (mapping._row_access, mapping.RowAccess),
    ],
)
def test_each_record_made_natively_is_the_record_of_those_fields(
    made: object, record: type
) -> None:
    # tuple.__new__ takes the fields by position: each maker's parameters are the record's
    # fields by name, and a field out of place would show as a different record
    fields = record._fields  # type: ignore[attr-defined]
    values = {name: f"<{name}>" for name in fields}
    assert made(**values) == record(**values)  # type: ignore[operator]
    assert type(made(**values)) is record  # type: ignore[operator]
