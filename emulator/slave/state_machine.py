"""The EtherCAT state machine (ESM) as the slave's application runs it behind the PDI.

ETG.1000.6 clause 6.4 (Figure/Table "state transitions") and the ESC datasheet section I,
chapter 10: the master requests a state in AL control (0x0120), the local application performs
the transition's checks and reports the state in AL status (0x0130) with the error indication
bit 4 and an AL status code (0x0134) when it refuses. Codes: ETG.1000.6 Table 11 / ETG.1020.

Transitions (datasheet I, Figure 40): INIT->PREOP (IP), PREOP->SAFEOP (PS), SAFEOP->OP (SO) and
every transition to a lower state (OS, OP, OI, SP, SI, PI); INIT->BOOT only for devices with a
bootstrap mode. Anything else is refused with 0x0011 "invalid requested state change", an
unknown state value with 0x0012, BOOT with 0x0013 "bootstrap not supported".

Errors and their acknowledge (ETG.1000.6 6.4.1.4 "error indication" and the state transition
table of 6.4.1; KickCAT's ``ESMStates.cc`` and the Beckhoff slave stack do the same):

* while the error indication is set, a request without the acknowledge bit (0x0120 bit 4) is
  ignored, except a request for INIT: the slave goes to INIT and clears the indication and the
  code (INIT is always reachable, and entering it resets the error);
* a request with the acknowledge bit clears the indication first, then is handled as any other;
* a refused request in OP (a transition that does not exist, e.g. OP->BOOT, or an unknown
  state) drops the slave to SAFEOP with the error indication and the code: an error in OP
  stops the outputs (ETG.1000.6: "OP -> SAFEOP with error indication"); in the other states
  the slave stays where it is, with the indication;
* an error the application detects itself (:meth:`SkinPatchApplication.local_error`, e.g. a
  SyncManager watchdog, 0x001B) does the same: OP drops to SAFEOP, other states keep theirs.
"""

from __future__ import annotations

import struct
from enum import IntEnum
from typing import TYPE_CHECKING, Final, Protocol

from emulator.esc.dc import REG_SAMPLE_TIME
from emulator.esc.pdi import Pdi
from emulator.slave.sii import SlaveInfo, SyncManagerType
from skinframes.ecat_mailbox import MailboxType

if TYPE_CHECKING:
    from emulator.slave.mailbox import Mailbox
    from emulator.slave.objects import ObjectDictionary, SkinDictionary

__all__ = [
    "ACK",
    "ERROR_INDICATION",
    "AlState",
    "AlStatusCode",
    "PdiApplication",
    "SkinPatchApplication",
    "SlaveApplication",
    "transition_code",
]

ACK: Final = 0x10  # AL control bit 4: error indication acknowledge
# Emergency error code of a refused PREOP->SAFEOP (or SAFEOP->OP) transition, the AL status code
# in the first two data bytes: the code Beckhoff slaves send (ETG.1000.6 5.6.4, ETG.1020 "EtherCAT
# state machine" emergencies 0xA000/0xA001)
EMERGENCY_PS_FAILED: Final = 0xA000
EMERGENCY_SO_FAILED: Final = 0xA001
ERROR_REGISTER_GENERIC: Final = 0x01  # 0x1001 bit 0 (CiA 301 7.5.2.2)
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
    """The slave application on the PDI side of an ESC (a microcontroller's firmware).

    It may also have ``mailbox_event(device)`` (after a frame that completed a mailbox buffer
    or wrote SyncManager registers) and ``outputs_event(device, index)`` (after a frame that
    completed the buffer of a process-data SyncManager the master writes, datasheet I 8.1):
    the ESC calls those it has (:class:`SlaveApplication` has both)."""

    def power_on(self, device: Pdi) -> None:
        """Called after the ESC loaded its EEPROM at power-on or reset."""

    def al_control(self, device: Pdi, value: int) -> None:
        """Called at the end of a frame that wrote AL control (0x0120) with ``value``."""


class SlaveApplication:
    """A slave's firmware behind the PDI: the ESM, the mailbox, the SyncManager checks, inputs.

    It behaves as the Beckhoff slave stack does: at power-on it deactivates every SyncManager
    through the PDI (0x0807 bit 0); a slave with a mailbox checks SM0/SM1 in INIT->PREOP (else
    0x0016) and releases them, and serves CoE from PREOP on (:mod:`emulator.slave.mailbox`,
    :mod:`emulator.slave.coe`, with the object dictionary :meth:`dictionary` gives); in
    PREOP->SAFEOP it checks that the master programmed each process-data SyncManager with the
    SII's start address, the length of the PDOs assigned to it (:meth:`sm_bytes`), mode and
    direction and enabled it (else 0x001E for inputs, 0x001D for outputs), then activates them
    and writes its inputs once; leaving SAFEOP deactivates them again. What a kind of slave adds
    (its dictionary, how its inputs are laid out) is in its subclass:
    :class:`SkinPatchApplication`, :class:`emulator.slave.esi_slave.EsiApplication`.
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
        self._image: list[tuple[int, int]] | None = None  # (offset, bytes) of assigned PDOs
        self.objects: ObjectDictionary | None = None
        self.mailbox: Mailbox | None = None
        if info.has_mailbox:
            from emulator.slave.coe import CoeServer
            from emulator.slave.mailbox import Mailbox

            self.objects = self.dictionary()
            tx = info.sync_managers[info.sm_of_type(SyncManagerType.MAILBOX_IN) or 0]
            coe = None if self.objects is None else CoeServer(self.objects, tx.length)
            self.mailbox = Mailbox(info, coe)
        self.outputs = bytes(info.output_bytes)

    def dictionary(self) -> ObjectDictionary | None:
        """The CoE object dictionary of a slave with a mailbox (None: no CoE)."""
        return None

    # --- the PDI application protocol ------------------------------------------------------
    def power_on(self, device: Pdi) -> None:
        """INIT, every SyncManager deactivated by the PDI (ESM state INIT)."""
        device.pdi_deactivate_sms(range(device.config.syncmanagers), True)
        if self.mailbox is not None:
            self.mailbox.stop(device)
        device.pdi_set_al_status(AlState.INIT, error=False, code=AlStatusCode.NO_ERROR)

    def mailbox_event(self, device: Pdi) -> None:
        """After a frame that touched a mailbox or a SyncManager register (device hook)."""
        if self.mailbox is not None:
            self.mailbox.service(device, device.al_status & STATE_MASK)

    def emergency(self, device: Pdi, code: int, data: bytes = b"") -> None:
        """Send an emergency message (ETG.1000.6 5.6.4) and set the error register 0x1001."""
        if self.mailbox is None or self.objects is None or not self.mailbox.active:
            return
        self.objects.error_register |= ERROR_REGISTER_GENERIC
        coe = self.mailbox.coe
        assert coe is not None
        self.mailbox.post(MailboxType.COE, coe.emergency(code, self.objects.error_register, data))
        self.mailbox.service(device, device.al_status & STATE_MASK)

    def al_control(self, device: Pdi, value: int) -> None:
        """Run the ESM on a write of AL control (ETG.1000.6 6.4)."""
        status = device.al_status
        current, error = status & STATE_MASK, bool(status & ERROR_INDICATION)
        requested, ack = value & STATE_MASK, bool(value & ACK)
        code = device.al_status_code
        if ack or (error and requested == AlState.INIT):
            # acknowledged, or INIT without acknowledge: INIT resets the error (6.4.1.4)
            error, code = False, AlStatusCode.NO_ERROR
        elif error:
            return  # an unacknowledged error blocks every request but INIT
        verdict = transition_code(current, requested)
        if verdict == AlStatusCode.NO_ERROR and requested != current:
            verdict = self._enter(device, current, requested)
        if verdict != AlStatusCode.NO_ERROR:
            self.local_error(device, verdict, current)
            if (current, requested) in (
                (AlState.PREOP, AlState.SAFEOP),
                (AlState.SAFEOP, AlState.OP),
            ):
                failed = EMERGENCY_PS_FAILED if current == AlState.PREOP else EMERGENCY_SO_FAILED
                self.emergency(device, failed, struct.pack("<HBB", verdict, current, requested))
            return
        if ack and self.objects is not None:
            self.objects.error_register = 0
        device.pdi_set_al_status(requested, error=error, code=code)

    def local_error(self, device: Pdi, code: AlStatusCode, current: int | None = None) -> None:
        """The application reports an error: the indication and ``code`` in AL status; in OP
        the slave drops to SAFEOP first (ETG.1000.6 6.4.1: an error in OP -> SAFEOP + error)."""
        state = device.al_status & STATE_MASK if current is None else current
        if state == AlState.OP:
            self._enter(device, AlState.OP, AlState.SAFEOP)
            state = AlState.SAFEOP
        device.pdi_set_al_status(state, error=True, code=code)

    # --- outputs -----------------------------------------------------------------------------
    def outputs_event(self, device: Pdi, index: int) -> None:
        """The master completed the buffer of output SyncManager ``index`` (its buffer exchange
        and event for the PDI, datasheet I 8.1, AL event 0x0220 bit 8 + index): read it through
        the PDI (which frees the buffer) and, in OP only, take the outputs
        (:meth:`take_outputs`); in SAFE-OP the outputs stay in their safe state (ETG.1000.6
        6.4.1, "Safe-Operational": outputs in safe state)."""
        start, length, _, _ = device.sm_registers(index)
        data = device.pdi_read(start, length)
        if device.al_status & STATE_MASK == AlState.OP:
            self.take_outputs(index, data)

    def take_outputs(self, index: int, data: bytes) -> None:
        """Outputs ``data`` of SyncManager ``index`` act: here they are held (:attr:`outputs`;
        a skin patch's dictionary reads its 0x7000 objects from them)."""
        self.outputs = data

    # --- inputs ------------------------------------------------------------------------------
    def publish(self, device: Pdi, data: bytes) -> None:
        """Write a complete input buffer through the PDI (a buffer exchange of SM inputs).

        While SYNC0 is active (emulator.esc.dc) the data is what the sensor holds; the patch
        samples it at the next SYNC0 pulse (:meth:`sync0`).
        """
        self.hold_inputs(data)
        if not device.dc_sampling:
            self._write_inputs(device)

    def hold_inputs(self, data: bytes) -> int | None:
        """The sensor holds ``data``, the slave's next inputs (all of them; else ValueError):
        :meth:`publish` without the write, which a line of patches does for all of them at once
        (:meth:`emulator.esc.chain.EcatChain.publish`). Where :meth:`_write_inputs` writes them
        as they are: the input SyncManager's start when they are its image (no PDO assignment
        reorders them); else None."""
        if len(data) != self._input_bytes or self._input_start is None:  # the whole patch
            raise ValueError(f"inputs: {len(data)} bytes, the PDO has {self._input_bytes}")
        self.inputs = data if type(data) is bytes else bytes(data)
        return self._input_start if self._image is None else None

    def _write_inputs(self, device: Pdi) -> None:
        """The held inputs into the input buffer, as the assigned PDOs map them."""
        assert self._input_start is not None
        if self._image is None:
            device.pdi_write(self._input_start, self.inputs)
        else:
            data = self.inputs
            device.pdi_write(self._input_start, b"".join(data[a : a + n] for a, n in self._image))

    # --- transitions --------------------------------------------------------------------------
    def _enter(self, device: Pdi, current: int, requested: int) -> AlStatusCode:
        if requested == AlState.PREOP and current == AlState.INIT and self.mailbox is not None:
            if not self.mailbox.configured(device):
                return AlStatusCode.INVALID_MAILBOX_CONFIGURATION
            self.mailbox.start(device)
        if requested == AlState.SAFEOP and current == AlState.PREOP:
            self._image = self._assigned_image()
            code = self._check_process_data_sms(device)
            if code != AlStatusCode.NO_ERROR:
                return code
            device.pdi_deactivate_sms((i for i, _ in self._pd_sms), False)
            self._first_inputs(device)  # valid inputs before acknowledging SAFEOP
        elif requested in (AlState.PREOP, AlState.INIT):
            mailbox = self.mailbox if requested == AlState.INIT else None
            locked = [i for i, _ in self._pd_sms]
            if mailbox is not None:  # its SyncManagers too, in the same rebuild
                locked += (mailbox.rx, mailbox.tx)
            device.pdi_deactivate_sms(locked, True)
            if mailbox is not None:
                mailbox.stop(device)
        return AlStatusCode.NO_ERROR

    def _first_inputs(self, device: Pdi) -> None:
        """The inputs held, written once while entering SAFEOP."""
        if self._input_start is not None:
            device.pdi_write(self._input_start, self.inputs)

    def sm_bytes(self, index: int) -> int:
        """Bytes of the PDOs assigned to SyncManager ``index`` (here: the SII's PDOs)."""
        return self.info.sm_bytes(index)

    def _assigned_image(self) -> list[tuple[int, int]] | None:
        """Where each assigned TxPDO's bytes lie in the inputs; None: the inputs are the image."""
        return None

    def _check_process_data_sms(self, device: Pdi) -> AlStatusCode:
        for i, spec in self._pd_sms:
            start, length, control, activate = device.sm_registers(i)
            expected_length = self.sm_bytes(i)
            if expected_length == 0:  # nothing assigned: the SyncManager must not run
                if activate & 1 and length:
                    return AlStatusCode.INVALID_OUTPUT_CONFIGURATION
                continue
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


class SkinPatchApplication(SlaveApplication):
    """The firmware of a skin patch: :class:`SlaveApplication` with the skin's dictionary
    (:mod:`emulator.slave.objects`), TxPDOs selected by assignment (0x1C13), and taxels sampled
    at SYNC0 pulses with the pulse's time stamped in user RAM 0x0F80."""

    objects: SkinDictionary | None

    def __init__(self, info: SlaveInfo) -> None:
        super().__init__(info)
        # what PREOP->SAFEOP reads of the SII's PDOs (ETG.2010 Table 11) at every slave: each
        # PDO's bits, by the kind of SyncManager it goes to, and where each TxPDO lies in the
        # patch's inputs
        self._pdo_bits = {
            SyncManagerType.INPUTS: {p.index: p.bit_length for p in info.tx_pdos},
            SyncManagerType.OUTPUTS: {p.index: p.bit_length for p in info.rx_pdos},
        }
        self._tx_order = [p.index for p in info.tx_pdos]
        self._tx_at: dict[int, tuple[int, int]] = {}
        at = 0
        for p in info.tx_pdos:
            self._tx_at[p.index] = (at, p.bit_length // 8)
            at += p.bit_length // 8

    def dictionary(self) -> SkinDictionary:
        """The skin patch's dictionary; taxels and outputs read live."""
        from emulator.slave.objects import skin_dictionary

        return skin_dictionary(self.info, lambda: self.inputs, lambda: self.outputs)

    def sync0(self, device: Pdi, pulse_ns: int) -> None:
        """A SYNC0 pulse at system time ``pulse_ns``: sample the taxels, stamp the sample
        (user RAM 0x0F80, emulator.esc.dc.REG_SAMPLE_TIME)."""
        if self._input_start is not None:
            device.pdi_write(REG_SAMPLE_TIME, pulse_ns.to_bytes(8, "little"))
            self._write_inputs(device)

    def sm_bytes(self, index: int) -> int:
        """Bytes of the PDOs assigned to SyncManager ``index``: 0x1C12/0x1C13 with CoE (SM2
        outputs, SM3 inputs), else the SII's PDOs."""
        if self.objects is None:
            return self.info.sm_bytes(index)
        kind = self.info.sync_managers[index].type
        if kind == SyncManagerType.INPUTS:
            assigned = self.objects.tx_pdos()
        elif kind == SyncManagerType.OUTPUTS:
            assigned = self.objects.rx_pdos()
        else:
            return 0
        bits = self._pdo_bits[kind]
        return (sum(bits[i] for i in assigned) + 7) // 8

    def _assigned_image(self) -> list[tuple[int, int]] | None:
        """Where each assigned TxPDO's bytes lie in the patch's inputs; None when all are
        assigned in SII order (the inputs are the image)."""
        if self.objects is None:
            return None
        assigned = self.objects.tx_pdos()
        if assigned == self._tx_order:
            return None
        return [self._tx_at[i] for i in assigned]
