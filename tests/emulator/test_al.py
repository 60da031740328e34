"""AL control and status (emulator.esc.al), the expected bytes worked out by hand from the ESC
datasheet: II 0x0120 (AL control, a mailbox to the PDI unless device emulation), 0x0130 and
0x0134 (AL status, AL status code), 0x0141 bit 0 (device emulation), 0x0210 bit 3 (AL status
event)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from emulator.esc import al


@dataclass
class Esc:
    al_control_full: bool = False
    pdi_operational: bool = True
    statuses: list[tuple[int, bool, int]] = field(default_factory=list)

    def pdi_set_al_status(self, state: int, *, error: bool, code: int) -> None:
        self.statuses.append((state, error, code))


def test_the_pdi_writes_al_status_and_code_and_the_event_where_the_status_changed() -> None:
    mem = bytearray(0x1000)
    mem[0x0130] = 0x01  # INIT, as after power-on
    assert al.status_written(mem, 0x12, error=True, code=0x001E)  # state bits 0-3 only: 2
    assert mem[0x0130:0x0136] == bytes([0x12, 0x00, 0, 0, 0x1E, 0x00])  # PREOP + error bit 4
    assert mem[0x0210] == 0x08  # AL status event (ECAT event request, II 0x0210 bit 3)
    mem[0x0210] = 0
    assert not al.status_written(mem, 0x02, error=True, code=0x0011)  # the same status
    assert mem[0x0130:0x0136] == bytes([0x12, 0x00, 0, 0, 0x11, 0x00])  # the code still written
    assert mem[0x0210] == 0


def test_al_control_is_a_mailbox_unless_device_emulation() -> None:
    memory = np.zeros((4, 0x1000), np.uint8)
    memory[1, 0x0141] = 0x01  # device emulation
    memory[3, 0x0141] = 0x01
    escs = [Esc(False), Esc(True), Esc(True), Esc(False)]
    free = al.control_free(escs, memory, np.arange(4))
    assert free.tolist() == [True, True, False, True]  # the third: full, no device emulation


def test_a_write_of_al_control_fills_the_mailbox_and_the_esc_or_the_firmware_reacts() -> None:
    memory = np.zeros((3, 0x1000), np.uint8)
    memory[:, 0x0120:0x0122] = [[0x04, 0x00], [0x12, 0x00], [0x08, 0x00]]
    memory[1, 0x0141] = 0x01  # device emulation: AL status follows at once, code 0
    escs = [Esc(), Esc(), Esc(pdi_operational=False)]
    firmware = al.control_written(escs, memory, np.arange(3), np.array([0, 1, 2]))
    assert [e.al_control_full for e in escs] == [True, False, True]
    assert firmware == [(escs[0], 0x0004)]  # the firmware reacts; no PDI: no firmware at all
    assert [e.statuses for e in escs] == [[], [(0x02, True, 0)], []]
