"""The ESC's planned LRD (one whole input buffer through one byte-wise FMMU, the process data of
every cycle), and an LRW that no FMMU of the ESC writes, answer as the general path (FMMU,
physical read, SyncManager) does, frame by frame and SyncManager register by register: in the
cases the plan must leave to the general path (a buffer the PDI locked, a SyncManager turned
around to ECAT writes, an FMMU that writes where the LRW reaches) and under hostile frames."""

from __future__ import annotations

import struct
from collections.abc import Callable

import numpy as np
import pytest

from emulator.esc.chain import EcatChain, configure_frames, skin_devices
from emulator.esc.device import REG_SM
from emulator.hostile import hostile_frames, master_reset_frames
from emulator.slave.sii import SyncManagerType
from skinframes import ethercat, taxel
from skinframes.ethercat import Command, Datagram, EcatFrame

NODES, SIZE = 6, 8
IMAGE = NODES * SIZE
ROWS = taxel.sample_payloads(NODES, 8, SIZE, seed=2)


def general(chain: EcatChain) -> EcatChain:
    """``chain`` with every ESC's plan refused: each LRD takes the general path."""
    for dev in chain.devices:
        dev._plan_lrd = lambda key: None  # type: ignore[method-assign]
    return chain


def frame(*dgs: Datagram) -> bytes:
    return ethercat.frame(EcatFrame(dgs)).to_bytes()


def lrd(lad: int, n: int) -> bytes:
    return frame(Datagram.logical(Command.LRD, lad, bytes(n)))


def lrw(lad: int, n: int) -> bytes:
    return frame(Datagram.logical(Command.LRW, lad, bytes(range(n))))


def answered(chain: EcatChain, frame: bytes) -> Datagram:
    """The first datagram of ``frame`` as ``chain`` returns it."""
    back = chain.process_frame(frame)
    assert back is not None
    return ethercat.decode(back[14:])[0].datagrams[0]


def bwr(ado: int, data: bytes) -> bytes:
    return frame(Datagram(Command.BWR, 0, ado, data))


def same(planned: EcatChain, reference: EcatChain, frames: list[bytes]) -> None:
    """Both chains answer every frame alike and keep the same SyncManager registers."""
    for i, f in enumerate(frames):
        assert planned.process_frame(f) == reference.process_frame(f), f"frame {i}"
        for a, b in zip(planned.devices, reference.devices, strict=True):
            assert a.registers(REG_SM, 0x80) == b.registers(REG_SM, 0x80), f"frame {i}"


def lock_sm0(chain: EcatChain) -> None:
    chain.devices[2].pdi_deactivate_sms((0,), True)


def sm0_to_ecat_writes(chain: EcatChain) -> None:
    for f in (bwr(0x0806, b"\x00"), bwr(0x0804, b"\x24"), bwr(0x0806, b"\x01")):
        chain.process_frame(f)


def fmmu1_writes_after_the_image(chain: EcatChain) -> None:
    """FMMU 1 of every ESC writes logical IMAGE..IMAGE+3 into user RAM at 0x0F80."""
    chain.process_frame(bwr(0x0610, struct.pack("<IHBBHBBB3x", IMAGE, 4, 0, 7, 0x0F80, 0, 2, 1)))


def nothing(chain: EcatChain) -> None:
    pass


@pytest.mark.parametrize(
    "change", [nothing, lock_sm0, sm0_to_ecat_writes, fmmu1_writes_after_the_image]
)
def test_planned_lrds_answer_as_the_general_path(change: Callable[[EcatChain], None]) -> None:
    planned = EcatChain.configured(NODES, SIZE)
    reference = general(EcatChain.configured(NODES, SIZE))
    for chain in (planned, reference):
        change(chain)
    ordinary = [lrd(0, IMAGE), lrd(SIZE, SIZE), lrd(3, 2 * SIZE), lrd(0, IMAGE + 5)]
    ordinary += [lrw(0, IMAGE), lrw(SIZE, SIZE), lrw(0, IMAGE + 5)]
    for k in range(len(ROWS)):
        for chain in (planned, reference):
            chain.publish(np.ascontiguousarray(ROWS[k]))  # a new buffer: the SM's write event
        same(planned, reference, ordinary)
    used = [p for dev in planned.devices for p in dev._lrd_plans.values() if p is not None]
    # planned where the buffer is a read one (the PDI's lock is looked at when reading)
    assert bool(used) == (change is not sm0_to_ecat_writes)
    if change is nothing:
        back = answered(planned, lrd(0, IMAGE))
        assert (back.data, back.wkc) == (ROWS[-1].tobytes(), NODES)
        back = answered(planned, lrw(0, IMAGE))
        assert (back.data, back.wkc) == (ROWS[-1].tobytes(), NODES)  # read only: 1 an ESC
    if change is fmmu1_writes_after_the_image:  # each ESC reads its inputs and writes 4 bytes
        back = answered(planned, lrw(0, IMAGE + 5))
        assert back.wkc == 3 * NODES  # ETG.1000.4 Table 14: +1 read, +2 write
        assert planned.devices[0].registers(0x0F80, 4) == bytes(range(IMAGE, IMAGE + 4))


def test_planned_lrds_answer_as_the_general_path_under_hostile_frames() -> None:
    planned = EcatChain.configured(NODES, SIZE)
    reference = general(EcatChain.configured(NODES, SIZE))
    ordinary = [lrd(0, IMAGE), lrd(SIZE, SIZE), lrd(0, IMAGE + 5), lrw(0, IMAGE), lrw(0, IMAGE + 5)]
    setup = master_reset_frames(NODES) + configure_frames(planned.devices[0].info, NODES)
    for i, f in enumerate(hostile_frames(1_500, nodes=NODES, input_bytes=SIZE, seed=9)):
        if i % 50 == 0:
            for chain in (planned, reference):
                chain.publish(np.ascontiguousarray(ROWS[i // 50 % len(ROWS)]))
        same(planned, reference, [f, *ordinary, *(setup if i % 100 == 99 else [])])
    for a, b in zip(planned.devices, reference.devices, strict=True):
        assert a.registers(0, 0x10000) == b.registers(0, 0x10000)


def test_a_line_of_two_buffer_sizes_reads_every_patch_in_one_lrd() -> None:
    # three patches of 4 input bytes, then two of 6: the LRD of the 24-byte image reads each
    # patch's buffer where its FMMU maps it (4 bytes a patch, then 6), each counting 1
    # (ETG.1000.4 Table 14), and reads it again unchanged until the PDI writes a new one
    chain = EcatChain.configured(3, 4, devices=skin_devices(2, 6))
    inputs = [bytes([0x10 * (p + 1) + i for i in range(4 if p < 3 else 6)]) for p in range(5)]
    for dev, data in zip(chain.devices, inputs, strict=True):
        dev.app.publish(dev, data)  # type: ignore[attr-defined]
    for _ in range(2):
        (d,) = ethercat.decode(chain.process_frame(lrd(0, 24))[14:])[0].datagrams
        assert (d.data, d.wkc) == (b"".join(inputs), 5)
        for dev in chain.devices:  # SyncManager status 0x0805+: read, closed (datasheet II)
            index = dev.info.sm_of_type(SyncManagerType.INPUTS)
            assert index is not None
            status = dev.registers(REG_SM + 8 * index + 5, 1)[0]
            assert (status & 0x42, status & 0x01) == (0x02, 0)  # read IRQ, not open; no write IRQ
    chain.devices[4].app.publish(chain.devices[4], b"\xaa" * 6)  # type: ignore[attr-defined]
    (d,) = ethercat.decode(chain.process_frame(lrd(0, 24))[14:])[0].datagrams
    assert d.data == b"".join(inputs[:4]) + b"\xaa" * 6
