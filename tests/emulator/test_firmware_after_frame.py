"""The slaves' applications (their firmware) react to a frame once it has passed: the ESCs answer
first (``EcatChain.answer``), the ESM and the mailbox follow (``EcatChain.run_firmware``), and
what the master sees in the next frame is what it saw when the firmware reacted at once."""

from __future__ import annotations

import numpy as np
import pytest

from emulator.esc.chain import EcatChain, configure_frames
from emulator.hostile import hostile_frames, master_reset_frames
from skinframes import ethercat
from skinframes.ethercat import Command, Datagram, EcatFrame

NODES, SIZE = 6, 8
AL_CONTROL, AL_STATUS, RESET = 0x0120, 0x0130, 0x0040


def frame(*datagrams: Datagram) -> bytes:
    return ethercat.frame(EcatFrame(datagrams)).to_bytes()


def al_status(chain: EcatChain) -> list[int]:
    return [
        dev.registers(AL_STATUS, 2)[0] | dev.registers(AL_STATUS, 2)[1] << 8
        for dev in chain.devices
    ]


def test_the_answer_comes_before_the_firmware_reacts() -> None:
    """A BWR of AL control asking OP slaves for PREOP (ETG.1000.6 6.4) is answered by every ESC
    (working counter 6) while AL status still says OP (0x08); the ESM then takes each slave to
    PREOP (0x02)."""
    chain = EcatChain.configured(NODES, SIZE)
    assert al_status(chain) == [0x08] * NODES
    back = chain.answer(frame(Datagram(Command.BWR, 0, AL_CONTROL, b"\x02\x00")))
    assert back is not None
    (d,) = ethercat.decode(back[14:])[0].datagrams
    assert d.wkc == NODES
    assert al_status(chain) == [0x08] * NODES and len(chain.firmware) == NODES
    chain.run_firmware()
    assert al_status(chain) == [0x02] * NODES and not chain.firmware


@pytest.mark.parametrize("mailbox", [False, True])
def test_an_esc_reset_in_the_frame_comes_after_the_firmware_saw_the_frame(mailbox: bool) -> None:
    """The frame that completes the reset sequence ('R', 'E', 'S' to 0x0040, datasheet II 2.3)
    also asks for PREOP. The firmware sees that request before the ESC resets, so the slave
    ends in INIT without error (AL status 0x01), as after any reset; a request handled after the
    reset would have found INIT and taken the slave to PREOP (0x02), or, with a mailbox whose
    SyncManagers the reset cleared, refused it (0x11)."""
    chain = EcatChain.skin(NODES, SIZE, mailbox=mailbox)
    for f in configure_frames(chain.devices[0].info, NODES):
        chain.process_frame(f)
    assert al_status(chain) == [0x08] * NODES
    chain.process_frame(frame(Datagram(Command.BWR, 0, RESET, b"R")))
    chain.process_frame(frame(Datagram(Command.BWR, 0, RESET, b"E")))
    last = (
        Datagram(Command.BWR, 0, RESET, b"S"),
        Datagram(Command.BWR, 0, AL_CONTROL, b"\x02\x00"),
    )
    assert chain.process_frame(frame(*last)) is not None
    assert al_status(chain) == [0x01] * NODES


def test_firmware_after_the_frame_leaves_what_firmware_at_once_leaves() -> None:
    """Under hostile frames (AL control, SyncManager and mailbox writes among them), a chain
    whose slaves' firmware reacts after each frame returns the same frames and leaves the same
    memory as one whose firmware reacts inside the frame, at the end of each ESC's part."""
    for mailbox in (False, True):
        later, at_once = (EcatChain.skin(NODES, SIZE, mailbox=mailbox) for _ in range(2))
        for dev in at_once.devices:
            dev.firmware_queue = None  # the application reacts as the ESC ends the frame
        setup = master_reset_frames(NODES) + configure_frames(later.devices[0].info, NODES)
        for g in setup:
            assert later.process_frame(g) == at_once.process_frame(g)
        for i, f in enumerate(hostile_frames(3_000, nodes=NODES, input_bytes=SIZE, seed=21)):
            assert later.process_frame(f) == at_once.process_frame(f), f"frame {i}"
            assert np.array_equal(later.memory, at_once.memory), f"frame {i}"
            if i % 300 == 299:
                for g in setup:
                    assert later.process_frame(g) == at_once.process_frame(g)


def test_the_next_frame_runs_the_reactions_nobody_ran() -> None:
    """``answer`` leaves the reactions for later; if nobody runs them, the next frame does, before
    its own work: a BRD of AL status after a PREOP request answered but not reacted to reads
    PREOP (0x02, ORed over the slaves), and nothing is left held."""
    chain = EcatChain.configured(NODES, SIZE)
    chain.answer(frame(Datagram(Command.BWR, 0, AL_CONTROL, b"\x02\x00")))
    assert len(chain.firmware) == NODES
    back = chain.answer(frame(Datagram(Command.BRD, 0, AL_STATUS, bytes(2))))
    assert back is not None
    (d,) = ethercat.decode(back[14:])[0].datagrams
    assert (d.data, d.wkc) == (b"\x02\x00", NODES) and not chain.firmware
