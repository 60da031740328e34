"""The mailbox of an emulated slave: SM0 master -> slave, SM1 slave -> master.

ETG.1000.4 5.6 / ETG.1000.6 5.6.1 and the ESC datasheet I 8.2 (mailbox mode) and II 2.14:

* the master writes a whole message into SM0 (mailbox full, 0x0805 bit 3, until the slave's
  application has read it); the application writes each answer into SM1, where it stays until
  the master has read it up to the end address (then SM1 is empty again);
* each message begins with the mailbox header (:mod:`skinframes.ecat_mailbox`); its counter
  (1..7) tells a new message from a repeated one: a received message with the counter of the
  previous one is a repetition (the master did not see its write acknowledged) and is dropped;
  the slave numbers its own messages 1..7 the same way;
* repeat request (datasheet II 2.14.6/2.14.7): when the master toggles SM1's repeat bit
  (0x0806 bit 1, ETG.1000.4 5.6 "mailbox repeat"), because a read of SM1 was lost on the way
  back, the application puts its last message into SM1 again and then sets the repeat
  acknowledge (0x0807 bit 1) to the repeat bit; SOEM's ``ecx_mbxreceive`` does exactly that;
* a message of a protocol the slave does not offer, or with a bad length, is answered with a
  mailbox error reply (type 0, ETG.1000.6 Table 30).

Answers queue while SM1 is full and follow one another as the master empties it. The handler runs
at the end of every frame that completed a mailbox buffer or changed a SyncManager register
(:meth:`emulator.esc.device.EscDevice.end_frame`), so a request is answered before the master's
next frame: a fast firmware.
"""

from __future__ import annotations

from collections import deque
from typing import Final

from emulator.esc.pdi import Pdi
from emulator.esc.registers import REG_SM, SM_BYTES, SM_MAILBOX_FULL
from emulator.slave.coe import CoeServer
from emulator.slave.sii import SlaveInfo, SyncManagerType
from skinframes import ecat_mailbox as mb
from skinframes.ecat_mailbox import MailboxErrorCode, MailboxHeader, MailboxType

__all__ = ["Mailbox"]

SM_REPEAT: Final = 0x02  # 0x0806 bit 1 (ECAT) and 0x0807 bit 1 (PDI: repeat acknowledge)


class Mailbox:
    """One slave's mailbox state and the protocols behind it (CoE only)."""

    def __init__(self, info: SlaveInfo, coe: CoeServer | None) -> None:
        rx = info.sm_of_type(SyncManagerType.MAILBOX_OUT)
        tx = info.sm_of_type(SyncManagerType.MAILBOX_IN)
        if rx is None or tx is None:
            raise ValueError("mailbox: the SII has no mailbox SyncManagers")
        self.rx, self.tx = rx, tx
        self.rx_spec, self.tx_spec = info.sync_managers[rx], info.sync_managers[tx]
        self.coe = coe
        self.active = False
        self.outbox: deque[tuple[int, bytes]] = deque()  # (type, body) not yet in SM1
        self.last: bytes | None = None  # the last message put into SM1 (for a repeat)
        self.counter_in: int | None = None
        self.counter_out = 0
        self.received = 0  # messages taken from SM0 (repetitions included)
        self.sent = 0  # messages put into SM1 (repeats included)

    # --- configuration (ESM INIT -> PREOP and back) -------------------------------------------
    def configured(self, device: Pdi) -> bool:
        """SM0/SM1 programmed as the SII says: start, length, mode and direction, enabled."""
        for index, spec in ((self.rx, self.rx_spec), (self.tx, self.tx_spec)):
            start, length, control, activate = device.sm_registers(index)
            if (
                start != spec.start
                or length != spec.length
                or control & 0x0F != spec.control & 0x0F
                or not activate & 0x01
            ):
                return False
        return True

    def start(self, device: Pdi) -> None:
        """Release SM0/SM1 to the master (entering PREOP) with an empty mailbox."""
        self._reset()
        device.pdi_deactivate_sms((self.rx, self.tx), False)
        device.pdi_set_repeat_ack(self.tx, bool(self._repeat(device)))
        self.active = True

    def stop(self, device: Pdi) -> None:
        """Lock SM0/SM1 again (back to INIT); queued messages are dropped."""
        self._reset()
        self.active = False
        device.pdi_deactivate_sms((self.rx, self.tx), True)

    def _reset(self) -> None:
        self.outbox.clear()
        self.last = None
        self.counter_in = None
        self.counter_out = 0
        if self.coe is not None:
            self.coe.reset()

    # --- the application's side -------------------------------------------------------------
    def post(self, kind: int, body: bytes) -> None:
        """Queue a message for the master (sent when SM1 is empty)."""
        self.outbox.append((kind, body))

    def service(self, device: Pdi, state: int) -> None:
        """What the application does after a frame: repeat, receive, send."""
        if not self.active:
            return
        repeat = self._repeat(device)
        if repeat != device.registers(REG_SM + SM_BYTES * self.tx + 7, 1)[0] & SM_REPEAT:
            if not self._full(device, self.tx) and self.last is not None:
                self._put(device, self.last)
            device.pdi_set_repeat_ack(self.tx, bool(repeat))
        if self._full(device, self.rx):
            message = device.pdi_read(self.rx_spec.start, self.rx_spec.length)
            self.received += 1
            self._receive(message, state)
        if self.outbox and not self._full(device, self.tx):
            kind, body = self.outbox.popleft()
            self.counter_out = mb.next_counter(self.counter_out)
            self._put(device, mb.mailbox(kind, body, self.counter_out, size=self.tx_spec.length))

    def _receive(self, message: bytes, state: int) -> None:
        head = MailboxHeader.from_bytes(message)
        if head.counter and head.counter == self.counter_in:
            return  # a repetition of the message already handled (ETG.1000.6 5.6.1)
        self.counter_in = head.counter
        if head.length < mb.COE_HEADER_BYTES:
            self.post(MailboxType.ERROR, mb.mailbox_error(MailboxErrorCode.SIZE_TOO_SHORT))
            return
        if head.length > len(message) - mb.MAILBOX_HEADER_BYTES:
            self.post(MailboxType.ERROR, mb.mailbox_error(MailboxErrorCode.INVALID_SIZE))
            return
        if head.type != MailboxType.COE or self.coe is None:
            self.post(MailboxType.ERROR, mb.mailbox_error(MailboxErrorCode.UNSUPPORTED_PROTOCOL))
            return
        body = message[mb.MAILBOX_HEADER_BYTES : mb.MAILBOX_HEADER_BYTES + head.length]
        for answer in self.coe.handle(body, state):
            if answer:
                self.post(MailboxType.COE, answer)

    def _put(self, device: Pdi, message: bytes) -> None:
        self.last = message
        self.sent += 1
        device.pdi_write(self.tx_spec.start, message)

    @staticmethod
    def _full(device: Pdi, index: int) -> bool:
        return bool(device.registers(REG_SM + SM_BYTES * index + 5, 1)[0] & SM_MAILBOX_FULL)

    def _repeat(self, device: Pdi) -> int:
        return device.registers(REG_SM + SM_BYTES * self.tx + 6, 1)[0] & SM_REPEAT
