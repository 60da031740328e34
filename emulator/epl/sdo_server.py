"""The SDO server of an emulated CN: sequence layer and command layer over ASnd (DS 301 6.3.2).

Sequence layer (DS 301 6.3.2.3, Tables 51-52, Fig. 56): the client opens with (rcon 0, scon 1
Initialization); the server answers (1, 1); the client confirms (1, 2) and the server (2, 2):
the connection is valid. Every later frame that carries a command advances its sender's 6-bit
sequence number by one and acknowledges the other's last one in its receive sequence number; a
frame with scon 3 asks for an acknowledgement at once; a frame whose number skips ahead means
lost frames, answered with rcon 3 (error response), and an rcon 3 from the client makes the
server send again the frames it has not acknowledged (kept in a short history); scon 0 closes.

The numbers and the history are :class:`~emulator.epl.sdo_seq.SequenceLayer`'s, shared with
the MN's SDO client.

Command layer (DS 301 6.3.2.4): WriteByIndex and ReadByIndex, expedited (one segment) and
segmented (an initiate segment with the DataSize, then segments, the last one "complete"); every
other command and every refused access is answered with an abort and its DS 301 abort code.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Final

from emulator.epl.od import ObjectDictionary
from emulator.epl.sdo_seq import NEW_WINDOW, SequenceLayer
from emulator.errors import SdoAbortError
from skinframes.errors import DecodeError
from skinframes.powerlink import Sdo, SdoCommand
from skinframes.powerlink.sdo import (
    MAX_SEGMENT_BYTES,
    AbortCode,
    CommandId,
    Segmentation,
    SequenceCon,
    abort_data,
    pack_data_size,
    unpack_data_size,
    unpack_index,
)

MAX_DOWNLOAD_BYTES: Final = 4096  # a segmented write larger than any object here is refused


@dataclass
class _Download:
    """A segmented WriteByIndex under way."""

    transaction_id: int
    index: int
    subindex: int
    size_bytes: int
    data: bytearray


@dataclass
class SdoServer:
    """One CN's SDO server (one connection at a time, as openPOWERLINK's CN).

    :meth:`receive` takes each SDO frame addressed to the node and returns the SDO frames to
    send back, in order. ``counts`` names what went wrong (for the served node's report).
    """

    od: ObjectDictionary
    connected: bool = False
    initialising: bool = False
    seq: SequenceLayer = field(default_factory=SequenceLayer)
    counts: Counter[str] = field(default_factory=Counter)
    _download: _Download | None = None

    def close(self) -> None:
        """Drop the connection (and any segmented transfer)."""
        self.connected = self.initialising = False
        self.seq.clear()
        self._download = None

    def receive(self, sdo: Sdo) -> list[Sdo]:
        """One SDO frame from the client; the frames to send back (none, one or more)."""
        rcon, scon = sdo.receive_con, sdo.send_con
        if scon == SequenceCon.NO_CONNECTION:  # close (DS 301 6.3.2.3: scon 0)
            if self.connected or self.initialising:
                self.counts["sdo_closed"] += 1
            self.close()
            return []
        if scon == SequenceCon.INITIALIZATION and rcon == SequenceCon.NO_CONNECTION:
            self.close()
            self.initialising = True
            self.seq.recv_seq = sdo.send_sequence
            self.seq.send_seq = 0
            init = SequenceCon.INITIALIZATION
            return [self.seq.frame(None, advance=False, receive_con=init, send_con=init)]
        if self.initialising:
            if rcon == SequenceCon.INITIALIZATION and scon == SequenceCon.CONNECTION_VALID:
                if sdo.receive_sequence != self.seq.send_seq:
                    return self._sequence_error(sdo, "init acknowledges a number never sent")
                self.initialising, self.connected = False, True
                self.seq.recv_seq = sdo.send_sequence
                return [self.seq.frame(None, advance=False)]
            return self._sequence_error(sdo, "connection set-up out of order")
        if not self.connected:  # DS 301 6.3.2.3: answered "no connection" if it carries a command
            self.counts["sdo_no_connection"] += 1
            if sdo.command is None:
                return []
            return [Sdo(sdo.send_sequence, SequenceCon.NO_CONNECTION, 0, SequenceCon.NO_CONNECTION)]
        out: list[Sdo] = []
        self.seq.acknowledged(sdo.receive_sequence)
        if rcon == SequenceCon.ERROR_OR_ACK_REQUEST:  # the client lost frames: send them again
            self.counts["sdo_retransmissions"] += len(self.seq.history)
            out += self.seq.again()
        ahead = self.seq.ahead(sdo)
        if ahead == 0 or ahead >= NEW_WINDOW:  # an acknowledgement, or an old frame again
            if scon == SequenceCon.ERROR_OR_ACK_REQUEST and not out:
                out.append(self.seq.frame(None, advance=False))
            return out
        if ahead > 1:  # frames lost: ask for them again (rcon 3 = error response)
            self.counts["sdo_lost_frames"] += ahead - 1
            error = SequenceCon.ERROR_OR_ACK_REQUEST
            return [*out, self.seq.frame(None, advance=False, receive_con=error)]
        self.seq.recv_seq = sdo.send_sequence
        responses = self._command(sdo.command) if sdo.command is not None else []
        if responses:
            out += [self.seq.frame(c, advance=True) for c in responses]
        else:  # a segment without a response of its own, or no command: acknowledge it
            out.append(self.seq.frame(None, advance=False))
        return out

    def _sequence_error(self, sdo: Sdo, why: str) -> list[Sdo]:
        self.counts["sdo_sequence_errors"] += 1
        self.close()
        return [Sdo(sdo.send_sequence, SequenceCon.ERROR_OR_ACK_REQUEST, self.seq.send_seq, 0)]

    # --- command layer -----------------------------------------------------------------------
    def _command(self, c: SdoCommand) -> list[SdoCommand]:
        if c.response:  # a client's frame never is a response: ignore it
            self.counts["sdo_bad_commands"] += 1
            return []
        if c.abort:  # the client aborts the transfer under way
            self.counts["sdo_client_aborts"] += 1
            self._download = None
            return []
        if c.command_id == CommandId.NIL:
            return []
        try:
            if c.command_id == CommandId.WRITE_BY_INDEX:
                return self._write(c)
            if c.command_id == CommandId.READ_BY_INDEX:
                return self._read(c)
            raise SdoAbortError(
                AbortCode.UNKNOWN_COMMAND, f"command {c.command_id:#04x} not served"
            )
        except SdoAbortError as exc:
            self.counts["sdo_aborts"] += 1
            self._download = None
            return [self._abort(c, exc.code)]
        except DecodeError:
            self.counts["sdo_aborts"] += 1
            self._download = None
            return [self._abort(c, AbortCode.GENERAL_ERROR)]

    @staticmethod
    def _abort(c: SdoCommand, code: int) -> SdoCommand:
        return SdoCommand(
            c.transaction_id, c.command_id, abort_data(code), response=True, abort=True
        )

    def _write(self, c: SdoCommand) -> list[SdoCommand]:
        seg = c.segmentation
        if seg == Segmentation.EXPEDITED:
            index, subindex, value = unpack_index(c.data)
            self.od.write(index, subindex, value)
            return [SdoCommand(c.transaction_id, c.command_id, response=True)]
        if seg == Segmentation.INITIATE:
            size, rest = unpack_data_size(c.data)
            index, subindex, first = unpack_index(rest)
            if size > MAX_DOWNLOAD_BYTES:
                raise SdoAbortError(AbortCode.OUT_OF_MEMORY, f"a {size}-byte download")
            self._download = _Download(c.transaction_id, index, subindex, size, bytearray(first))
            return []
        d = self._download
        if d is None or d.transaction_id != c.transaction_id:
            raise SdoAbortError(AbortCode.UNKNOWN_COMMAND, "a segment of no transfer")
        d.data += c.data
        if len(d.data) > d.size_bytes:
            raise SdoAbortError(AbortCode.LENGTH_TOO_HIGH, "segments past the data size")
        if seg != Segmentation.COMPLETE:
            return []
        self._download = None
        if len(d.data) != d.size_bytes:
            raise SdoAbortError(AbortCode.LENGTH_TOO_LOW, "fewer bytes than the data size")
        self.od.write(d.index, d.subindex, bytes(d.data))
        return [SdoCommand(c.transaction_id, c.command_id, response=True)]

    def _read(self, c: SdoCommand) -> list[SdoCommand]:
        if c.segmentation != Segmentation.EXPEDITED:
            raise SdoAbortError(AbortCode.UNKNOWN_COMMAND, "a segmented ReadByIndex request")
        index, subindex, _ = unpack_index(c.data)
        value = self.od.read(index, subindex)
        tid, cid = c.transaction_id, c.command_id
        if len(value) <= MAX_SEGMENT_BYTES:
            return [SdoCommand(tid, cid, value, response=True)]
        first = MAX_SEGMENT_BYTES - 4  # the initiate segment carries the DataSize too
        out = [
            SdoCommand(
                tid,
                cid,
                pack_data_size(len(value)) + value[:first],
                response=True,
                segmentation=Segmentation.INITIATE,
            )
        ]
        pos = first
        while pos < len(value):
            chunk = value[pos : pos + MAX_SEGMENT_BYTES]
            pos += len(chunk)
            last = pos >= len(value)
            seg = Segmentation.COMPLETE if last else Segmentation.SEGMENT
            out.append(SdoCommand(tid, cid, chunk, response=True, segmentation=seg))
        return out
