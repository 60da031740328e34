"""The emulated MN's SDO client: a CN's configuration written by index over ASnd (DS 301 6.3.2).

One :class:`SdoClient` per CN runs a list of expedited WriteByIndex transfers (the objects of the
node's 0x1F22 block, in order) on one connection, as openPOWERLINK's MN does at boot (the kit's
README, "What the oPL MN sends a CN at boot", step 5):

- sequence layer (6.3.2.3): the client opens with (rcon 0, scon 1 Initialization), the server
  answers (1, 1), the client confirms (1, 2 valid) and the server's (2, 2) makes the connection
  valid; each command frame then takes the next send sequence number and acknowledges the
  server's last one (:class:`~emulator.epl.sdo_seq.SequenceLayer`, shared with the CN's server);
  a server frame that reports lost frames (rcon 3) makes the client send the unacknowledged ones
  again; the transfer list done, the client closes (scon 0);
- command layer (6.3.2.4): WriteByIndex (0x01), expedited (Index, SubIndex, reserved, data),
  transaction ids 0, 1, 2, ...; an abort from the server ends the list (``failed``).

The client only says what to send (:meth:`SdoClient.next_frame`) and takes what comes back
(:meth:`SdoClient.receive`); when and how frames travel is the MN's (one per asynchronous slot).
"""

from __future__ import annotations

import enum
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Final

from emulator.epl.sdo_seq import NEW_WINDOW, SequenceLayer
from skinframes.powerlink import Sdo, SdoCommand
from skinframes.powerlink.cdc import CdcEntry
from skinframes.powerlink.sdo import (
    CommandId,
    SequenceCon,
    pack_index,
)

TRANSACTION_MODULO = 64  # the command layer's TransactionID is 6 bits (DS 301 6.3.2.4.1)


class Phase(enum.Enum):
    """Where the client is."""

    IDLE = "idle"  # nothing sent yet
    OPENING = "opening"  # InitReq sent, waiting for the server's (1, 1)
    CONFIRMING = "confirming"  # (1, 2) to send
    CONFIRMED = "confirmed"  # (1, 2) sent, waiting for the server's (2, 2)
    READY = "ready"  # connection valid, the next write to send
    WAITING = "waiting"  # a write sent, waiting for its response
    CLOSING = "closing"  # every write done: the close to send
    DONE = "done"  # closed after every write succeeded
    FAILED = "failed"  # an abort or a sequence error: closed


# The server's frames that set the connection up (rcon, scon) and where each leads
_INIT = (SequenceCon.INITIALIZATION, SequenceCon.INITIALIZATION)
_VALID = (SequenceCon.CONNECTION_VALID, SequenceCon.CONNECTION_VALID)
HANDSHAKE: Final = {
    Phase.OPENING: (_INIT, Phase.CONFIRMING),
    Phase.CONFIRMED: (_VALID, Phase.READY),
}


@dataclass
class SdoClient:
    """Writes ``writes`` (in order) to one CN."""

    writes: Sequence[CdcEntry]
    phase: Phase = Phase.IDLE
    seq: SequenceLayer = field(default_factory=SequenceLayer)
    done: int = 0  # writes acknowledged
    abort_code: int | None = None  # the server's abort, when it aborted
    failed_write: CdcEntry | None = None
    counts: Counter[str] = field(default_factory=Counter)
    _again: list[Sdo] = field(default_factory=list)

    @property
    def waiting(self) -> bool:
        """Whether the server owes a frame (the MN should invite the CN to send)."""
        return self.phase in (Phase.OPENING, Phase.CONFIRMED, Phase.WAITING)

    @property
    def finished(self) -> bool:
        """Whether the client has nothing more to send or wait for."""
        return self.phase in (Phase.DONE, Phase.FAILED)

    def next_frame(self) -> Sdo | None:
        """The frame to send now (None: nothing, or waiting for the server)."""
        if self._again:
            return self._again.pop(0)
        if self.phase is Phase.IDLE:
            self.seq.clear()
            self.phase = Phase.OPENING
            return Sdo(0, SequenceCon.NO_CONNECTION, 0, SequenceCon.INITIALIZATION)
        if self.phase is Phase.CONFIRMING:
            self.phase = Phase.CONFIRMED
            return self.seq.frame(None, advance=False, receive_con=SequenceCon.INITIALIZATION)
        if self.phase is Phase.READY:
            if self.done >= len(self.writes):
                self.phase = Phase.CLOSING
            else:
                self.phase = Phase.WAITING
                return self.seq.frame(self._write(self.done), advance=True)
        if self.phase is Phase.CLOSING:
            self.phase = Phase.DONE
            return self._close()
        return None

    def _write(self, k: int) -> SdoCommand:
        entry = self.writes[k]
        data = pack_index(entry.index, entry.subindex) + entry.data
        return SdoCommand(k % TRANSACTION_MODULO, CommandId.WRITE_BY_INDEX, data)

    def _close(self) -> Sdo:
        return Sdo(self.seq.recv_seq, SequenceCon.NO_CONNECTION, self.seq.send_seq, 0)

    def _fail(self, why: str) -> None:
        self.counts[why] += 1
        self.phase = Phase.FAILED
        self._again = [self._close()]

    def receive(self, sdo: Sdo) -> None:
        """One SDO frame from the server."""
        rcon, scon = sdo.receive_con, sdo.send_con
        handshake = HANDSHAKE.get(self.phase)
        if handshake is not None:  # the connection's set-up: the one frame expected, or nothing
            expected, after = handshake
            if (rcon, scon) == expected:
                self.seq.recv_seq = sdo.send_sequence
                self.phase = after
            else:
                self.counts["sdo_unexpected"] += 1
            return
        if self.phase not in (Phase.READY, Phase.WAITING):
            self.counts["sdo_unexpected"] += 1
            return
        if scon == SequenceCon.NO_CONNECTION or rcon == SequenceCon.NO_CONNECTION:
            self._fail("sdo_closed_by_server")
            return
        self.seq.acknowledged(sdo.receive_sequence)
        if rcon == SequenceCon.ERROR_OR_ACK_REQUEST:  # the server lost frames: send them again
            self.counts["sdo_retransmissions"] += len(self.seq.history)
            self._again = self.seq.again()
        ahead = self.seq.ahead(sdo)
        if ahead == 0 or ahead >= NEW_WINDOW:  # an acknowledgement only, or an old frame
            return
        self.seq.recv_seq = sdo.send_sequence
        command = sdo.command
        if command is None or not command.response or self.phase is not Phase.WAITING:
            return
        if command.transaction_id != self.done % TRANSACTION_MODULO:
            self.counts["sdo_unexpected"] += 1
            return
        if command.abort:
            self.abort_code = int.from_bytes(command.data[:4], "little")
            self.failed_write = self.writes[self.done]
            self._fail("sdo_aborts")
            return
        self.done += 1
        self.phase = Phase.READY
