"""A frame processed datagram by datagram, with broadcasts read and committed at every ESC at once
(:meth:`EcatChain._run_planned`, :mod:`emulator.esc.together`), leaves the same bytes as the
general path, ESC by ESC and datagram by datagram (:meth:`EcatChain._pass`, the path of
:meth:`EcatChain.frame_effect`): the same returned frame, memory, EEPROM, event request and
forwarding at every ESC, frame after frame, under hostile frames and register traffic aimed at
what the shortcuts take over (plain registers, read-write offsets, aliases, loops closed early)."""

from __future__ import annotations

import random
import struct
from typing import Any

import numpy as np
import pytest
from one_by_one import OneByOne

from emulator.errors import TopologyError
from emulator.esc import device as esc_device
from emulator.esc import together
from emulator.esc.chain import EcatChain, configure_frames
from emulator.esc.device import EscDevice
from emulator.esc.mapping import decode_sms
from emulator.esc.registers import REG_SM, SM_BYTES, SM_NO_BUFFER
from emulator.esc.syncmanagers import SmRun
from emulator.hostile import hostile_frames, master_reset_frames
from emulator.slave.sii import SyncManagerType, crc8
from skinframes import ethercat, taxel
from skinframes.ethercat import Command, Datagram, EcatFrame

NODES, SIZE = 8, 8
ROWS = taxel.sample_payloads(NODES, 4, SIZE, seed=5)
# registers where a broadcast lands in the shortcuts, or just beside them
SPOTS = (
    0x0000, 0x0010, 0x0012, 0x003E, 0x0040, 0x0100, 0x0101, 0x0103, 0x0108, 0x010E, 0x0110,
    0x0120, 0x012F, 0x0130, 0x0134, 0x0200, 0x0210, 0x0300, 0x030C, 0x0310, 0x0440, 0x0500,
    0x0502, 0x0508, 0x0600, 0x0610, 0x06F0, 0x0800, 0x0805, 0x0808, 0x0870, 0x08FC, 0x0900,
    0x0910, 0x0920, 0x0980, 0x09FE, 0x0F70, 0x0F7E, 0x0FF0, 0x1000,
)  # fmt: skip
BROADCASTS = (Command.BRD, Command.BWR, Command.BRW, Command.ARMW, Command.FRMW)
OTHERS = (Command.APWR, Command.APRD, Command.FPWR, Command.FPRW, Command.LRD, Command.LWR)


def register_frame(rng: random.Random) -> bytes:
    """1-6 datagrams, mostly broadcasts and read-multiple-writes near ``SPOTS``; the data keeps
    the EEPROM write enable (0x0502 bit 0) clear, as the hostile frames do."""
    dgs = []
    for _ in range(rng.randint(1, 6)):
        cmd = rng.choice(BROADCASTS) if rng.random() < 0.8 else rng.choice(OTHERS)
        ado = (rng.choice(SPOTS) + rng.randrange(-2, 3)) & 0xFFFF
        data = bytearray(rng.randbytes(rng.choice((0, 1, 2, 4, 8, rng.randrange(40)))))
        if ado <= 0x0502 < ado + len(data):
            data[0x0502 - ado] &= 0xFE
        if ado <= 0x0040 < ado + len(data) and rng.random() < 0.7:
            data[0x0040 - ado] = rng.choice(b"RES")  # the reset sequence, now and then whole
        adp = rng.choice((0, -rng.randrange(NODES + 2) & 0xFFFF, 0x1001 + rng.randrange(NODES)))
        if cmd in (Command.LRD, Command.LWR):
            dgs.append(Datagram.logical(cmd, rng.randrange(NODES * SIZE), bytes(data)))
        else:
            dgs.append(Datagram(cmd, adp, ado, bytes(data)))
    return ethercat.frame(EcatFrame(tuple(dgs))).to_bytes()


def disturb(chain: EcatChain, k: int) -> None:
    """What frames cannot do: the PDI of one ESC takes the EEPROM interface (0x0501 bit 0), and
    errors count at another (invalid frames, lost links), so that a write can clear them."""
    dev = chain.devices[k % NODES]
    dev.pdi_write(0x0501, bytes((dev.registers(0x0501, 1)[0] ^ 0x01,)))
    for register in (0x0300, 0x0301, 0x030C, 0x0310, 0x0313):
        chain.count(register, (k + 3) % NODES, k + 1)


def assert_same(fast: EcatChain, reference: EcatChain, frame: bytes, what: str) -> None:
    assert fast.process_frame(frame) == reference.process_frame(frame), what
    assert np.array_equal(fast.memory, reference.memory), what
    for a, b in zip(fast.devices, reference.devices, strict=True):
        assert (a.sii, a.irq, a.onward, a.sets_mac) == (b.sii, b.irq, b.onward, b.sets_mac), what


def pair() -> tuple[EcatChain, EcatChain]:
    return EcatChain.configured(NODES, SIZE), OneByOne.configured(NODES, SIZE)


@pytest.mark.parametrize("seed", [1, 2])
def test_register_traffic_leaves_the_same_bytes(seed: int) -> None:
    rng = random.Random(seed)
    fast, reference = pair()
    setup = master_reset_frames(NODES) + configure_frames(fast.devices[0].info, NODES)
    for i in range(1_500):
        if i % 100 == 0:
            for chain in (fast, reference):
                chain.publish(np.ascontiguousarray(ROWS[i // 100 % len(ROWS)]))
        if i % 100 == 50:
            for chain in (fast, reference):
                disturb(chain, i // 100)
        assert_same(fast, reference, register_frame(rng), f"seed {seed}, frame {i}")
        if i % 300 == 299:
            for f in setup:
                assert_same(fast, reference, f, f"setup after frame {i}")


def test_hostile_frames_leave_the_same_bytes() -> None:
    fast, reference = pair()
    setup = master_reset_frames(NODES) + configure_frames(fast.devices[0].info, NODES)
    for i, f in enumerate(hostile_frames(2_000, nodes=NODES, input_bytes=SIZE, seed=4)):
        assert_same(fast, reference, f, f"frame {i}")
        if i % 200 == 199:
            for g in setup:
                assert_same(fast, reference, g, f"setup after frame {i}")


def bwr(ado: int, data: bytes) -> bytes:
    return ethercat.frame(EcatFrame((Datagram(Command.BWR, 0, ado, data),))).to_bytes()


def test_equal_writes_are_committed_together(monkeypatch: pytest.MonkeyPatch) -> None:
    """The shortcut is taken (a broadcast's commit runs once, over rows), and it is the one that
    decides: an ESC whose commit is skipped there leaves different bytes."""
    fast, reference = pair()
    calls: list[int] = []
    commit = together.commit_together

    def counted(devices, memory, rows, **kwargs):  # type: ignore[no-untyped-def]
        calls.append(len(devices))
        commit(devices, memory, rows, **kwargs)

    monkeypatch.setattr("emulator.esc.chain.commit_together", counted)
    assert_same(fast, reference, bwr(0x0200, b"\x04\x00"), "event mask")
    assert calls == [NODES]

    def skipped(devices, memory, rows, **kwargs):  # type: ignore[no-untyped-def]
        for dev in devices:
            dev.pending.clear()

    monkeypatch.setattr("emulator.esc.chain.commit_together", skipped)
    with pytest.raises(AssertionError):
        assert_same(fast, reference, bwr(0x0200, b"\x00\x00"), "event mask cleared")


def test_eeprom_commands_written_at_every_esc_clear_and_set_their_status_bits() -> None:
    """Broadcasts of EEPROM control 0x0502 (ECAT owns the interface at every ESC): the write
    enable (bit 0) and the command (bits 8-10) self-clear; no command clears the error bits, an
    invalid one (7) sets the acknowledge error (bit 13, datasheet I 11.2.3), a write (2)
    without write enable the write enable error (bit 14); a read (1) of word 0 brings the
    EEPROM's first 8 bytes to 0x0508. Bit 6, read-only, says the ESC reads 8
    bytes at a time. Alike at each of 8 ESCs and as each ESC on its own does it."""
    fast, reference = pair()
    first = fast.devices[0].sii[:8]
    for data, status, what in (
        (b"\x01\x07", b"\x40\x20", "invalid command: acknowledge error"),
        (b"\x01\x00", b"\x40\x00", "no command: errors cleared, write enable too"),
        (b"\x00\x07", b"\x40\x20", "invalid command again"),
        (b"\x00\x01", b"\x40\x20", "a read: the error bits stay"),
        (b"\x00\x02", b"\x40\x60", "a write without write enable: its error as well"),
        (b"\x00\x00", b"\x40\x00", "no command clears both"),
    ):
        assert_same(fast, reference, bwr(0x0502, data), what)
        for dev in fast.devices:
            assert dev.registers(0x0502, 2) == status, what
    for dev in fast.devices:
        assert dev.registers(0x0508, 8) == first


def test_eeprom_reads_at_every_esc_read_each_escs_own_eeprom_at_its_own_address() -> None:
    """A broadcast of the read command (0x0502 bits 8-10 = 1; ECAT owns the interface at every
    ESC) after each ESC was given its own word address (0x0504, by FPWR): each brings 8 bytes
    of its own EEPROM to 0x0508, a read at the last word wraps around to word 0 (a sequential
    read), and one beyond the EEPROM's size sets the acknowledge error (0x0502 bit 13) and
    leaves 0x0508 as it was (datasheet I 11.2.3). ESC 3's EEPROM differs from the others'.
    Alike at each of 8 ESCs and as each on its own."""
    fast, reference = pair()
    for chain in (fast, reference):
        chain.devices[3].sii[4:12] = bytes(range(0xA0, 0xA8))
    size = len(fast.devices[0].sii) // 2  # words
    words = [0, 2, 2, 2, size - 1, size, 0x10000 + 2, 7]
    setup = [
        Datagram(Command.FPWR, 0x1001 + p, 0x0504, struct.pack("<I", w))
        for p, w in enumerate(words)
    ]
    assert_same(fast, reference, ethercat.frame(EcatFrame(tuple(setup))).to_bytes(), "addresses")
    before = [dev.registers(0x0508, 8) for dev in fast.devices]
    assert_same(fast, reference, bwr(0x0502, b"\x00\x01"), "read")
    sii = bytes(fast.devices[0].sii)
    data = [dev.registers(0x0508, 8) for dev in fast.devices]
    assert data[0] == sii[0:8]
    assert data[1] == data[2] == sii[4:12]
    assert data[3] == bytes(range(0xA0, 0xA8))
    assert data[4] == sii[-2:] + sii[:6]  # the last word, then words 0-2
    assert data[5] == before[5] and data[6] == before[6]  # beyond the EEPROM: nothing read
    assert data[7] == sii[14:22]
    errors = [dev.registers(0x0503, 1)[0] & 0x20 for dev in fast.devices]
    assert errors == [0, 0, 0, 0, 0, 0x20, 0x20, 0]


def test_eeprom_reloads_at_every_esc_load_each_escs_configuration_area() -> None:
    """A broadcast of the reload command (0x0502 bits 8-10 = 4; ECAT owns the interface at
    every ESC): each ESC loads its configuration area A (SII words 0-7, datasheet I 11.1,
    Table 42) into PDI control 0x0140 (the link detection bits 1, 4-7 of 0x0141 kept: they load
    only at the first load), 0x0142-0x0144 and 0x0150-0x0153, and clears checksum error and
    not loaded (0x0502 bits 11, 12); one whose area has a wrong checksum sets both and loads
    nothing. ESCs 2 and 5 have another PDI configuration (word 1), ESC 6 a wrong checksum,
    ESCs 1 and 5 link detection bits set. Alike at each of 8 ESCs and as each on its own."""
    fast, reference = pair()
    for chain in (fast, reference):
        for p, dev in enumerate(chain.devices):
            if p in (2, 5):
                dev.sii[2:4] = b"\x34\x12"
                dev.sii[14] = crc8(bytes(dev.sii[:14]))
            if p == 6:
                dev.sii[14] ^= 0xFF
            if p in (1, 5):
                dev.mem[0x0141] |= 0xF2
            dev.mem[0x0150:0x0154] = b"\xee" * 4  # what the load overwrites
    assert_same(fast, reference, bwr(0x0502, b"\x00\x04"), "reload")
    status = [fast.devices[p].registers(0x0503, 1)[0] & 0x18 for p in range(NODES)]
    assert status == [0, 0, 0, 0, 0, 0, 0x18, 0, *([0] * (NODES - 8))]
    pdi = [fast.devices[p].registers(0x0150, 2) for p in (2, 5, 6)]
    assert pdi == [b"\x34\x12", b"\x34\x12", b"\xee\xee"]
    assert fast.devices[5].registers(0x0141, 1)[0] & 0xF2 == 0xF2


def test_al_control_written_at_every_esc_reaches_each_application_or_is_copied() -> None:
    """Broadcasts of AL control 0x0120 at 8 ESCs, 3 of them in device emulation (0x0141 bit 0,
    datasheet I 10.1.2): those copy the value to AL status 0x0130 at once, error indication
    (bit 4) included; the others' applications react once the frame has passed (the ESM).
    Alike at each ESC and as each on its own does it, request after request."""
    fast, reference = pair()
    emulating = (1, 4, 5)
    for chain in (fast, reference):
        for p in emulating:
            chain.devices[p].mem[0x0141] |= 0x01
    for value in (0x02, 0x12, 0x04, 0x01, 0x11):
        assert_same(fast, reference, bwr(0x0120, bytes((value, 0))), f"AL control {value:#x}")
        for p in emulating:
            assert fast.devices[p].registers(0x0130, 1)[0] == value


def fmmu(log: int, length: int, phys: int, bits: tuple[int, int, int], kind: int) -> bytes:
    """FMMU registers (datasheet II 2.13): logical start, length, start and stop bit, physical
    start and bit, type (1 read, 2 write), active."""
    return struct.pack("<IHBBHBBB3x", log, length, bits[0], bits[1], phys, bits[2], kind, 1)


@pytest.mark.parametrize("bits", [(0, 7, 0), (3, 4, 5)], ids=["byte-wise", "bit-wise"])
def test_an_lrd_of_buffers_and_plain_ram_reads_each_part_where_its_fmmu_maps_it(
    bits: tuple[int, int, int],
) -> None:
    """Each ESC's FMMU 0 maps its own 8 logical bytes onto its inputs' buffer (SyncManager 3, a
    buffer ECAT reads); a broadcast gives every ESC FMMU 4 too, reading the whole image from
    user RAM at 0x2000, where a broadcast wrote 64 bytes. An LRD of the image: each ESC reads
    its buffer into its own bytes, which FMMU 0 claims, and the RAM into the rest (datasheet I
    7); the frame leaves with the last ESC's reads. Byte-wise (hand-worked): the RAM's first 56
    bytes, then ESC 7's inputs; 8 ESCs count. The chain leaves the bytes each ESC on its own
    leaves."""
    fast, reference = pair()
    ram = bytes(range(0x40, 0x80))
    setup = ethercat.frame(
        EcatFrame((Datagram(Command.BWR, 0, 0x2000, ram), Datagram(Command.BWR, 0, 0x0640,
        fmmu(0, NODES * SIZE, 0x2000, bits, 1))))
    ).to_bytes()  # fmt: skip
    for chain in (fast, reference):
        chain.publish(np.ascontiguousarray(ROWS[2]))
    assert_same(fast, reference, setup, "RAM and FMMU 4")
    lrd = ethercat.frame(
        EcatFrame((Datagram.logical(Command.LRD, 0, bytes(NODES * SIZE)),))
    ).to_bytes()
    for k in range(2):
        assert_same(fast, reference, lrd, f"LRD {k}")
    back = fast.process_frame(lrd)
    assert back is not None
    (d,) = ethercat.decode(back[14:])[0].datagrams
    assert d.wkc == NODES
    if bits == (0, 7, 0):
        assert d.data == ram[: (NODES - 1) * SIZE] + ROWS[2][-1].tobytes()


def test_a_loop_closed_early_keeps_the_rest_out() -> None:
    """ESC 2 closes port 1: a broadcast read or write reaches ESCs 0-2 only, and an ARMW whose
    reader lies beyond writes at all three."""
    fast, reference = pair()
    close = ethercat.frame(
        EcatFrame((Datagram(Command.APWR, -2 & 0xFFFF, 0x0101, b"\x0c"),))
    ).to_bytes()
    assert_same(fast, reference, close, "close port 1 of ESC 2")
    frames = [
        ethercat.frame(EcatFrame((Datagram(Command.BRD, 0, 0x0010, bytes(2)),))).to_bytes(),
        bwr(0x0F00, b"\xaa\x55"),
        ethercat.frame(
            EcatFrame((Datagram(Command.ARMW, -5 & 0xFFFF, 0x0F00, b"\x11\x22"),))
        ).to_bytes(),
        ethercat.frame(EcatFrame((Datagram(Command.BRW, 0, 0x0F00, b"\x01\x02"),))).to_bytes(),
    ]
    for i, f in enumerate(frames):
        assert_same(fast, reference, f, f"frame {i}")
    back = fast.process_frame(frames[0])
    assert back is not None
    (d,) = ethercat.decode(back[14:])[0].datagrams
    assert d.wkc == 3  # hand count: ESCs 0, 1 and 2
    assert d.data == struct.pack("<H", 0x1001 | 0x1002 | 0x1003)


def test_an_esc_belongs_to_one_chain() -> None:
    """A chain keeps its ESCs' memory as its rows: an ESC already in a chain is refused."""
    chain = EcatChain.skin(2, SIZE)
    with pytest.raises(TopologyError, match="already in a chain"):
        EcatChain(chain.devices)


def sm_state(chain: EcatChain) -> list[list[tuple[object, ...]]]:
    """Every ESC's SyncManagers as it runs them: area, lock, buffer state (made first where
    all started anew and the ESC has not needed them yet)."""
    for dev in chain.devices:
        if dev._unmade is not None:
            dev._make_sms()
    return [
        [
            (sm.index, sm.start, sm.length, sm.locked, sm.open, sm.complete, sm.full, sm.buf)
            for sm in dev._active
        ]
        for dev in chain.devices
    ]


def rebuild_one_by_one(dev: EscDevice, enabled_before: bytes | None = None) -> None:
    """``EscDevice._rebuild_sms`` as it was before SyncManager changes were worked out once and
    shared (``mapping.sm_change``), and without its early return: each SyncManager compared
    with the object the ESC holds (the reference)."""
    mem, sms = dev.mem, dev._sms
    table = bytes(mem[REG_SM : REG_SM + SM_BYTES * len(sms)])
    decoded = decode_sms(table)
    order = sorted(range(len(decoded)), key=lambda i: (decoded[i][1], decoded[i][4] != 0))
    enabled = {e[0] for e in decoded}
    for y in range(len(sms)):
        if y not in enabled:  # disabled or too short: no buffer
            sms[y] = None
            mem[REG_SM + SM_BYTES * y + 5] = SM_NO_BUFFER
    controlling = []
    for y, start, length, control, pdi_locked in decoded:
        old = sms[y]
        if (
            old is None
            or (enabled_before is not None and not enabled_before[y] & 1)
            or old.start != start
            or old.length != length
        ):
            old = sms[y] = SmRun(y, start, length, control)
            mem[REG_SM + SM_BYTES * y + 5] = SM_NO_BUFFER
        old.locked = pdi_locked != 0
        controlling.append(old)
    dev._active = [controlling[i] for i in order]
    dev._lrd_plans.clear()
    dev.sm_areas = decoded


def test_syncmanager_changes_worked_out_once_do_what_each_esc_would(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A change of an ESC's SyncManager table does what comparing each SyncManager with the
    one the ESC holds does (:func:`rebuild_one_by_one`), whether worked out once and shared
    (``mapping.sm_change``), at one ESC or over the rows of many (``device._syncmanagers``);
    and register bytes that set no SyncManager (a disabled one's configuration, repeat and
    latch bits) change nothing: the ESC keeps its SyncManagers. Under hostile frames, which
    write SyncManager registers at every ESC, the chain leaves the bytes and SyncManager states
    of a chain whose ESCs rebuild them every time, one by one, and the SyncManagers the ESCs
    share while they are as new (``mapping.Caches.as_new``, the chain's) stay as new."""
    fast, reference = EcatChain.configured(NODES, SIZE), OneByOne.configured(NODES, SIZE)
    references = {id(dev) for dev in reference.devices}
    rebuild, change = EscDevice._rebuild_sms, EscDevice._change_sms
    by_rows = esc_device._syncmanagers
    change_all = EscDevice._change_syncmanagers_together
    calls = {"written": 0, "changed": 0, "by rows": 0}

    def either(self: EscDevice) -> None:  # (the PDI locks or releases SyncManagers)
        if id(self) in references:
            rebuild_one_by_one(self)
        else:
            rebuild(self)

    def changed(self: EscDevice, *args: Any) -> None:
        calls["changed"] += id(self) not in references
        change(self, *args)

    def counted_all(devices: Any, *args: Any) -> None:  # changed, and written
        devices = list(devices)
        calls["written"] += sum(id(dev) not in references for dev in devices)
        change_all(devices, *args)

    def rows(devices: Any, memory: Any, at: Any, which: Any, *args: Any, **kw: Any) -> None:
        calls["by rows"] += len(which) if kw.get("frame", True) else 0  # (a frame's commit)
        by_rows(devices, memory, at, which, *args, **kw)

    monkeypatch.setattr(esc_device, "_syncmanagers", rows)
    monkeypatch.setattr(EscDevice, "_rebuild_sms", either)
    monkeypatch.setattr(EscDevice, "_change_sms", changed)
    monkeypatch.setattr(EscDevice, "_change_syncmanagers_together", staticmethod(counted_all))
    written_all = EscDevice._sm_registers_written_together

    def counted_written(devices: Any) -> None:  # written alone, over the rows
        devices = list(devices)
        calls["written"] += sum(id(dev) not in references for dev in devices)
        written_all(devices)

    monkeypatch.setattr(EscDevice, "_sm_registers_written_together", staticmethod(counted_written))
    setup = master_reset_frames(NODES) + configure_frames(fast.devices[0].info, NODES)
    for i, f in enumerate(hostile_frames(3_000, nodes=NODES, input_bytes=SIZE, seed=9)):
        assert fast.process_frame(f) == reference.process_frame(f), f"frame {i}"
        assert np.array_equal(fast.memory, reference.memory), f"frame {i}"
        assert sm_state(fast) == sm_state(reference), f"frame {i}"
        if i % 300 == 299:
            for g in setup:
                assert fast.process_frame(g) == reference.process_frame(g)
    assert calls["changed"] > 1_000  # changes happened
    assert calls["by rows"] > 1_000  # many of them over the rows of several ESCs
    assert calls["written"] - calls["changed"] > 500  # and bytes that set none, often
    shared = [sm for made in fast.caches.as_new.values() for sm in made if sm is not None]
    assert len(shared) > 100  # ESCs shared SyncManagers as new, and none of them changed
    assert {(sm.open, sm.complete, sm.full, sm.buf) for sm in shared} == {
        (False, False, False, None)
    }


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_an_input_buffer_started_anew_is_read_and_exchanged_at_every_esc(
    kind: type[EcatChain],
) -> None:
    """Hand-worked: two BWRs disable the input SyncManager and enable it again, so that it
    starts anew at every ESC: no buffer (status 0x30), the same as-new SyncManager for all of
    them until one changes it. An LRD of the image then reads each ESC's whole buffer, which
    holds what its memory holds there (no buffer written since), and exchanges it at every ESC
    at the end of the frame: the read interrupt (bit 1) set and the buffer no longer open,
    0x32 (datasheet I 8.1, II 2.14.5); an ESC that took another's open buffer for its own
    would not exchange it (0x70, still open)."""
    chain = kind.configured(NODES, SIZE)
    y = chain.devices[0].info.sm_of_type(SyncManagerType.INPUTS)
    assert y is not None
    status, activate = REG_SM + SM_BYTES * y + 5, REG_SM + SM_BYTES * y + 6
    start = struct.unpack("<H", chain.devices[0].registers(REG_SM + SM_BYTES * y, 2))[0]
    for value in (b"\x00", b"\x01"):
        frame = EcatFrame((Datagram(Command.BWR, 0, activate, value),))
        chain.process_frame(ethercat.frame(frame).to_bytes())
    assert [dev.registers(status, 1)[0] for dev in chain.devices] == [0x30] * NODES
    chain.memory[:NODES, start : start + SIZE] = ROWS[1]
    lrd = Datagram.logical(Command.LRD, 0, bytes(NODES * SIZE))
    back = chain.process_frame(ethercat.frame(EcatFrame((lrd,))).to_bytes())
    assert back is not None
    read = ethercat.decode(back[14:])[0].datagrams[0]
    assert (read.wkc, read.data) == (NODES, ROWS[1].tobytes())
    assert [dev.registers(status, 1)[0] for dev in chain.devices] == [0x32] * NODES


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_a_buffer_read_in_the_frame_that_disables_its_syncmanager_is_not_exchanged(
    kind: type[EcatChain],
) -> None:
    """An LRD of the image reads every ESC's whole input buffer, and the same frame disables
    the input SyncManager (activate 0): at the end of the frame the SyncManager is gone, so the
    buffer exchange the read asked for does not happen (datasheet I 8.1). Its status register
    shows no buffer (0x30), not the read interrupt (bit 1) an exchange sets; the LRD still
    answers with the inputs it read."""
    chain = kind.configured(NODES, SIZE)
    chain.publish(np.ascontiguousarray(ROWS[0]))
    y = chain.devices[0].info.sm_of_type(SyncManagerType.INPUTS)
    assert y is not None
    status, activate = REG_SM + SM_BYTES * y + 5, REG_SM + SM_BYTES * y + 6
    lrd = Datagram.logical(Command.LRD, 0, bytes(NODES * SIZE))
    off = Datagram(Command.BWR, 0, activate, b"\x00")
    back = chain.process_frame(ethercat.frame(EcatFrame((lrd, off))).to_bytes())
    assert back is not None
    read, written = ethercat.decode(back[14:])[0].datagrams
    assert (read.wkc, read.data, written.wkc) == (NODES, ROWS[0].tobytes(), NODES)
    assert [dev.registers(status, 1)[0] for dev in chain.devices] == [0x30] * NODES


@pytest.mark.parametrize("kind", [EcatChain, OneByOne])
def test_a_read_multiple_write_with_many_addressed_escs(kind: type[EcatChain]) -> None:
    """Hand-worked (datasheet I Table 7, FRMW): every even ESC has station address 0 and reads,
    every odd one writes the data as it arrives there, what the even ESC before it read. RAM
    at 0x1800 holds p + 1 at ESC p: the frame returns ESC 6's 7; ESC p odd then holds p; every
    ESC counts 1. (Found costly: one address at all 160 ESCs, each a reader, took 24-52 ms.)"""
    chain = kind.configured(NODES, SIZE)
    for p in range(NODES):
        station = 0 if p % 2 == 0 else 0x1234
        dgs = (
            Datagram(Command.APWR, -p & 0xFFFF, 0x0010, struct.pack("<H", station)),
            Datagram(Command.APWR, -p & 0xFFFF, 0x1800, bytes([p + 1])),
        )
        assert chain.process_frame(ethercat.frame(EcatFrame(dgs)).to_bytes()) is not None
    frmw = ethercat.frame(EcatFrame((Datagram(Command.FRMW, 0, 0x1800, b"\xee"),))).to_bytes()
    back = chain.process_frame(frmw)
    assert back is not None
    d = ethercat.decode(back[14:])[0].datagrams[0]
    assert (d.data, d.wkc) == (bytes([NODES - 1]), NODES)  # ESC 6 (of 8) read its 7
    assert [int(chain.memory[p, 0x1800]) for p in range(NODES)] == [
        p + 1 if p % 2 == 0 else p for p in range(NODES)
    ]
