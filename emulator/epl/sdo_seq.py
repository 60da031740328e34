"""The SDO sequence layer's numbers of one connection (EPSG DS 301 V1.4.0 6.3.2.3), shared by the
emulated CN's SDO server (:mod:`.sdo_server`) and the emulated MN's SDO client (:mod:`.sdo_client`).

Each side keeps its own last sent sequence number (``send_seq``) and the other side's last
accepted one (``recv_seq``); a frame that carries a command advances ``send_seq`` by one (6 bits,
modulo 64) and acknowledges ``recv_seq`` in its ReceiveSequenceNumber. Frames sent and not yet
acknowledged are kept (``history``) to be sent again when the other side reports a loss
(ReceiveCon 3). openPOWERLINK's ``sdoseq.c`` keeps a history of 5 frames: so does this.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Final

from skinframes.powerlink import Sdo, SdoCommand
from skinframes.powerlink.sdo import SequenceCon, seq_add, seq_diff

HISTORY_FRAMES: Final = 5  # openPOWERLINK sdoseq.c SDO_HISTORY_SIZE
# A received sequence number this far ahead or more is an old one (openPOWERLINK sdoseq.c
# SDO_SEQ_NUM_THRESHOLD is 100 in units of 4, i.e. 25 numbers); nearer ones mean lost frames.
NEW_WINDOW: Final = 25


@dataclass
class SequenceLayer:
    """One side's sequence numbers and unacknowledged frames of one SDO connection."""

    send_seq: int = 0  # our last sent sequence number
    recv_seq: int = 0  # the other side's last accepted sequence number
    history: deque[Sdo] = field(default_factory=lambda: deque(maxlen=HISTORY_FRAMES))

    def clear(self) -> None:
        """Forget the connection: numbers back to 0, history empty."""
        self.send_seq = self.recv_seq = 0
        self.history.clear()

    def frame(
        self,
        command: SdoCommand | None,
        *,
        advance: bool,
        receive_con: int = SequenceCon.CONNECTION_VALID,
        send_con: int = SequenceCon.CONNECTION_VALID,
    ) -> Sdo:
        """The next frame acknowledging ``recv_seq``; ``advance``: it carries a command, so it
        takes the next sequence number and is kept until acknowledged."""
        if advance:
            self.send_seq = seq_add(self.send_seq)
        sdo = Sdo(self.recv_seq, receive_con, self.send_seq, send_con, command)
        if advance:
            self.history.append(sdo)
        return sdo

    def acknowledged(self, number: int) -> None:
        """Forget history frames up to the other side's ReceiveSequenceNumber ``number``."""
        while self.history and seq_diff(number, self.history[0].send_sequence) < NEW_WINDOW:
            self.history.popleft()

    def again(self) -> list[Sdo]:
        """The unacknowledged frames, to send again, acknowledging ``recv_seq`` as it is now."""
        return [
            Sdo(self.recv_seq, SequenceCon.CONNECTION_VALID, h.send_sequence, h.send_con, h.command)
            for h in self.history
        ]

    def ahead(self, sdo: Sdo) -> int:
        """How far ``sdo``'s SendSequenceNumber is past the last accepted one: 1 is the next
        frame, 0 an acknowledgement only, 2 or more (below NEW_WINDOW) frames lost between,
        NEW_WINDOW or more an old frame again."""
        return seq_diff(sdo.send_sequence, self.recv_seq)
