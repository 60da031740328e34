"""The EtherCAT state machine (ESM) as the slave's application runs it behind the PDI.

ETG.1000.6 clause 6.4 (Figure/Table "state transitions") and the ESC datasheet section I,
chapter 10: the master requests a state in AL control (0x0120), the local application performs
the transition's checks and reports the state in AL status (0x0130) with the error indication
bit 4 and an AL status code (0x0134) when it refuses. Codes: ETG.1000.6 Table 11 / ETG.1020.

Transitions (datasheet I, Figure 40): INIT->PREOP (IP), PREOP->SAFEOP (PS), SAFEOP->OP (SO) and
every transition to a lower state (OS, OP, OI, SP, SI, PI); INIT->BOOT only for devices with a
bootstrap mode. Anything else is refused with 0x0011 "invalid requested state change", an
unknown state value with 0x0012, BOOT with 0x0013 "bootstrap not supported".

While the error indication is set, a request without the acknowledge bit (0x0120 bit 4) is
ignored unless it asks for INIT (what the Beckhoff slave stack does: "the error has to be
acknowledged before"); a request with the acknowledge bit clears the indication first.
"""

from __future__ import annotations

from enum import IntEnum
from typing import TYPE_CHECKING, Final, Protocol

from emulator.esc.dc import REG_SAMPLE_TIME
from emulator.esc.sii import SlaveInfo, SyncManagerType

if TYPE_CHECKING:
    from emulator.esc.device import EscDevice

__all__ = [
    "ACK",
    "ERROR_INDICATION",
    "AlState",
    "AlStatusCode",
    "PdiApplication",
    "SkinPatchApplication",
    "transition_code",
]

ACK: Final = 0x10  # AL control bit 4: error indication acknowledge
ERROR_INDICATION: Final = 0x10  # AL status bit 4
STATE_MASK: Final = 0x0F


class AlState(IntEnum):
    """AL control/status values (datasheet I, Table 41)."""

    INIT = 0x1
    PREOP = 0x2
    BOOT = 0x3
    SAFEOP = 0x4
    OP = 0x8


class AlStatusCode(IntEnum):
    """AL status codes (ETG.1000.6 Table 11, ETG.1020 Table "AL status codes")."""

    NO_ERROR = 0x0000
    UNSPECIFIED_ERROR = 0x0001
    NO_MEMORY = 0x0002
    INVALID_STATE_CHANGE = 0x0011
    UNKNOWN_STATE = 0x0012
    BOOTSTRAP_NOT_SUPPORTED = 0x0013
    INVALID_MAILBOX_CONFIGURATION = 0x0016
    INVALID_SM_CONFIGURATION = 0x0017
    NO_VALID_INPUTS = 0x0018
    NO_VALID_OUTPUTS = 0x0019
    SYNC_ERROR = 0x001A
    SM_WATCHDOG = 0x001B
    INVALID_SM_TYPES = 0x001C
    INVALID_OUTPUT_CONFIGURATION = 0x001D
    INVALID_INPUT_CONFIGURATION = 0x001E
    INVALID_WATCHDOG_CONFIGURATION = 0x001F


_VALID_STATES: Final = frozenset(int(s) for s in AlState)
# The transitions of ETG.1000.6 Figure "ESM" (datasheet I, Figure 40), without BOOT.
_ALLOWED: Final = frozenset(
    {
        (AlState.INIT, AlState.PREOP),
        (AlState.PREOP, AlState.SAFEOP),
        (AlState.SAFEOP, AlState.OP),
        (AlState.OP, AlState.SAFEOP),
        (AlState.OP, AlState.PREOP),
        (AlState.OP, AlState.INIT),
        (AlState.SAFEOP, AlState.PREOP),
        (AlState.SAFEOP, AlState.INIT),
        (AlState.PREOP, AlState.INIT),
    }
)


def transition_code(current: int, requested: int) -> AlStatusCode:
    """The ESM's verdict on a requested transition, before any device-specific check."""
    if requested not in _VALID_STATES:
        return AlStatusCode.UNKNOWN_STATE
    if requested == current:
        return AlStatusCode.NO_ERROR
    if requested == AlState.BOOT:
        # only INIT->BOOT exists; a device without bootstrap refuses it with 0x0013
        if current == AlState.INIT:
            return AlStatusCode.BOOTSTRAP_NOT_SUPPORTED
        return AlStatusCode.INVALID_STATE_CHANGE
    if (current, requested) in _ALLOWED:
        return AlStatusCode.NO_ERROR
    return AlStatusCode.INVALID_STATE_CHANGE


class PdiApplication(Protocol):
    """The slave application on the PDI side of an ESC (a microcontroller's firmware)."""

    def power_on(self, device: EscDevice) -> None:
        """Called after the ESC loaded its EEPROM at power-on or reset."""

    def al_control(self, device: EscDevice, value: int) -> None:
        """Called at the end of a frame that wrote AL control (0x0120) with ``value``."""


class SkinPatchApplication:
    """The firmware of a skin patch: the ESM, SyncManager checks, taxels published by the PDI.

    It behaves as the Beckhoff slave stack does for a mailbox-less device: at power-on it
    deactivates every SyncManager through the PDI (0x0807 bit 0); in PREOP->SAFEOP it checks
    that the master programmed each process-data SyncManager with the SII's start address,
    length, mode and direction and enabled it (else 0x001E for inputs, 0x001D for outputs),
    then activates them and writes its inputs once; leaving SAFEOP deactivates them again.
    """

    def __init__(self, info: SlaveInfo) -> None:
        self.info = info
        self._input_bytes = info.input_bytes
        self.inputs = bytes(self._input_bytes)
        self._pd_sms = [
            (i, sm)
            for i, sm in enumerate(info.sync_managers)
            if sm.type in (SyncManagerType.INPUTS, SyncManagerType.OUTPUTS)
        ]
        self._input_sm = info.sm_of_type(SyncManagerType.INPUTS)
        self._input_start = (
            None if self._input_sm is None else info.sync_managers[self._input_sm].start
        )

    # --- the PDI application protocol ------------------------------------------------------
    def power_on(self, device: EscDevice) -> None:
        """INIT, every SyncManager deactivated by the PDI (ESM state INIT)."""
        for i in range(device.config.syncmanagers):
            device.pdi_deactivate_sm(i, True)
        device.pdi_set_al_status(AlState.INIT, error=False, code=AlStatusCode.NO_ERROR)

    def al_control(self, device: EscDevice, value: int) -> None:
        """Run the ESM on a write of AL control (ETG.1000.6 6.4)."""
        status = device.al_status
        current, error = status & STATE_MASK, bool(status & ERROR_INDICATION)
        requested, ack = value & STATE_MASK, bool(value & ACK)
        code = device.al_status_code
        if ack:
            error, code = False, AlStatusCode.NO_ERROR
        elif error and requested != AlState.INIT:
            return  # an unacknowledged error blocks every request but INIT
        verdict = transition_code(current, requested)
        if verdict == AlStatusCode.NO_ERROR and requested != current:
            verdict = self._enter(device, current, requested)
        if verdict != AlStatusCode.NO_ERROR:
            device.pdi_set_al_status(current, error=True, code=verdict)
            return
        device.pdi_set_al_status(requested, error=error, code=code)

    # --- inputs ------------------------------------------------------------------------------
    def publish(self, device: EscDevice, data: bytes) -> None:
        """Write a complete input buffer through the PDI (a buffer exchange of SM inputs).

        While SYNC0 is active (emulator.esc.dc) the data is what the sensor holds; the patch
        samples it at the next SYNC0 pulse (:meth:`sync0`).
        """
        if len(data) != self._input_bytes or self._input_start is None:
            raise ValueError(f"inputs: {len(data)} bytes, the PDO has {self._input_bytes}")
        self.inputs = bytes(data)
        if not device.dc_sampling:
            device.pdi_write(self._input_start, self.inputs)

    def sync0(self, device: EscDevice, pulse_ns: int) -> None:
        """A SYNC0 pulse at system time ``pulse_ns``: sample the taxels, stamp the sample
        (user RAM 0x0F80, emulator.esc.dc.REG_SAMPLE_TIME)."""
        if self._input_start is not None:
            device.pdi_write(REG_SAMPLE_TIME, pulse_ns.to_bytes(8, "little"))
            device.pdi_write(self._input_start, self.inputs)

    # --- transitions --------------------------------------------------------------------------
    def _enter(self, device: EscDevice, current: int, requested: int) -> AlStatusCode:
        if requested == AlState.SAFEOP and current == AlState.PREOP:
            code = self._check_process_data_sms(device)
            if code != AlStatusCode.NO_ERROR:
                return code
            for i, _ in self._pd_sms:
                device.pdi_deactivate_sm(i, False)
            if self._input_start is not None:  # valid inputs before acknowledging SAFEOP
                device.pdi_write(self._input_start, self.inputs)
        elif requested in (AlState.PREOP, AlState.INIT):
            for i, _ in self._pd_sms:
                device.pdi_deactivate_sm(i, True)
        return AlStatusCode.NO_ERROR

    def _check_process_data_sms(self, device: EscDevice) -> AlStatusCode:
        for i, spec in self._pd_sms:
            start, length, control, activate = device.sm_registers(i)
            expected_length = self.info.sm_bytes(i)
            ok = (
                start == spec.start
                and length == expected_length
                and control & 0x0F == spec.control & 0x0F  # mode and direction bits
                and (activate & 1 or expected_length == 0)
            )
            if not ok:
                if spec.type == SyncManagerType.INPUTS:
                    return AlStatusCode.INVALID_INPUT_CONFIGURATION
                return AlStatusCode.INVALID_OUTPUT_CONFIGURATION
        return AlStatusCode.NO_ERROR
