"""The CoE server of an emulated slave: SDO transfers, SDO information, emergencies.

ETG.1000.6 5.6 (CANopen over EtherCAT) on top of an :class:`~emulator.slave.objects.ObjectDictionary`:

* SDO download (5.6.2.1-5.6.2.3) expedited (1-4 bytes in the request), normal (the size and as
  much data as the mailbox holds) and segmented (the rest in download segments, toggle bit
  alternating from 0); SDO upload (5.6.2.4-5.6.2.6) expedited for up to 4 bytes, normal, and
  segmented when the value does not fit one mailbox; complete access (bit 4 of the command) for
  ARRAY/RECORD objects from subindex 0 or 1; abort transfer (5.6.2.7) in both directions;
* SDO information (5.6.3): the object list (list types 0-5), object descriptions and entry
  descriptions (access rights, PDO mappability, no unit/default/minimum/maximum), in fragments
  when a response does not fit one mailbox; unknown objects are answered with an SDO
  information error;
* emergency messages (5.6.4), queued like any response.

The server sees CoE bodies (what follows the mailbox header) and returns CoE bodies; the mailbox
layer (:mod:`emulator.slave.mailbox`) frames them.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Final

from emulator.slave.objects import (
    RXPDO_MAPPABLE,
    TXPDO_MAPPABLE,
    ObjectDictionary,
)
from skinframes import ecat_mailbox as mb
from skinframes.ecat_mailbox import CoeService, SdoAbort, SdoInfoOpcode

__all__ = ["CoeServer"]

_SDO = struct.Struct("<BHB")  # command, index, subindex
_U32 = struct.Struct("<I")
MIN_SDO_BYTES: Final = mb.COE_HEADER_BYTES + mb.SDO_HEADER_BYTES  # 10: the shortest SDO
SEGMENT_HEADER_BYTES: Final = mb.COE_HEADER_BYTES + 1  # CoE header + command
MIN_SEGMENT_DATA: Final = 7  # a segment carries at least 7 bytes (CiA 301 7.2.4.3.4)
# OD list types (ETG.1000.6 Table 45): 0 = the lengths of lists 1-5
LIST_LENGTHS, LIST_ALL, LIST_RXPDO, LIST_TXPDO, LIST_BACKUP, LIST_STARTUP = range(6)


@dataclass
class _Transfer:
    """A segmented transfer in progress."""

    index: int
    subindex: int
    complete_access: bool
    data: bytearray
    size: int  # download: the announced size
    toggle: int = 0


class CoeServer:
    """Answers CoE requests from ``od``; ``mailbox_bytes`` is the send mailbox's size."""

    def __init__(self, od: ObjectDictionary, mailbox_bytes: int) -> None:
        self.od = od
        self.room = mailbox_bytes - mb.MAILBOX_HEADER_BYTES  # CoE bytes per message
        self._upload: _Transfer | None = None
        self._download: _Transfer | None = None

    def reset(self) -> None:
        """Forget transfers in progress (the mailbox was reset)."""
        self._upload = self._download = None

    def handle(self, body: bytes, state: int) -> list[bytes]:
        """The CoE bodies answering the CoE body ``body`` received in AL state ``state``."""
        _, service = mb.parse_coe_header(body)
        if service == CoeService.SDO_REQUEST:
            return [self._sdo(body, state)] if len(body) >= MIN_SDO_BYTES else []
        if service == CoeService.SDO_INFORMATION:
            return self._info(body)
        return []  # PDO services over the mailbox are not offered: nothing to answer

    def emergency(self, error_code: int, error_register: int, data: bytes = b"") -> bytes:
        """The CoE body of an emergency message (ETG.1000.6 5.6.4)."""
        return mb.emergency(error_code, error_register, data)

    # --- SDO ------------------------------------------------------------------------------------
    def _sdo(self, body: bytes, state: int) -> bytes:
        command, index, subindex = _SDO.unpack_from(body, mb.COE_HEADER_BYTES)
        ccs = command >> 5
        if ccs == mb.CS_ABORT:
            self.reset()
            return b""
        if ccs == mb.CCS_UPLOAD_INITIATE:
            self._upload = None
            return self._upload_initiate(index, subindex, bool(command & 0x10), state)
        if ccs == mb.CCS_UPLOAD_SEGMENT:
            return self._upload_segment(command, body)
        if ccs == mb.CCS_DOWNLOAD_INITIATE:
            self._download = None
            return self._download_initiate(command, index, subindex, body, state)
        if ccs == mb.CCS_DOWNLOAD_SEGMENT:
            return self._download_segment(command, body, state)
        return self._abort(index, subindex, SdoAbort.UNKNOWN_COMMAND)

    @staticmethod
    def _abort(index: int, subindex: int, code: int) -> bytes:
        # "Abort SDO Transfer Request": service 2 (SDO request) from either side (ETG.1000.6
        # 5.6.2.7); SOEM recognises a slave's abort by that, not by the response service
        return mb.sdo_abort(index, subindex, code)

    @staticmethod
    def _response(command: int, index: int, subindex: int, payload: bytes) -> bytes:
        return (
            mb.coe_header(CoeService.SDO_RESPONSE) + _SDO.pack(command, index, subindex) + payload
        )

    def _upload_initiate(self, index: int, subindex: int, ca: bool, state: int) -> bytes:
        value = (
            self.od.read_complete(index, subindex, state)
            if ca
            else self.od.read(index, subindex, state)
        )
        if isinstance(value, int):
            return self._abort(index, subindex, value)
        scs = mb.SCS_UPLOAD_INITIATE << 5 | (mb.SDO_COMPLETE_ACCESS if ca else 0)
        if len(value) <= 4 and not ca:  # expedited: n = bytes of the 4 without data
            command = scs | (4 - len(value)) << 2 | mb.SDO_EXPEDITED | mb.SDO_SIZE_INDICATED
            return self._response(command, index, subindex, value + bytes(4 - len(value)))
        first = self.room - MIN_SDO_BYTES
        if len(value) > first:
            self._upload = _Transfer(index, subindex, ca, bytearray(value[first:]), len(value))
        command = scs | mb.SDO_SIZE_INDICATED
        return self._response(command, index, subindex, _U32.pack(len(value)) + value[:first])

    def _segment_check(self, t: _Transfer | None, command: int) -> bytes | None:
        """The abort for a segment without a transfer or with the wrong toggle bit, or None."""
        if t is None:
            return self._abort(0, 0, SdoAbort.UNKNOWN_COMMAND)
        if command & mb.SDO_TOGGLE != t.toggle:
            self.reset()
            return self._abort(t.index, t.subindex, SdoAbort.TOGGLE_BIT)
        return None

    def _upload_segment(self, command: int, body: bytes) -> bytes:
        t = self._upload
        refused = self._segment_check(t, command)
        if refused is not None or t is None:
            return refused or b""
        toggle = command & mb.SDO_TOGGLE
        room = self.room - SEGMENT_HEADER_BYTES
        seg, rest = bytes(t.data[:room]), t.data[room:]
        last = not rest
        reply = mb.SCS_UPLOAD_SEGMENT << 5 | toggle | (mb.SDO_LAST_SEGMENT if last else 0)
        if len(seg) < MIN_SEGMENT_DATA:
            reply |= (MIN_SEGMENT_DATA - len(seg)) << 1
            seg += bytes(MIN_SEGMENT_DATA - len(seg))
        if last:
            self._upload = None
        else:
            t.data, t.toggle = rest, toggle ^ mb.SDO_TOGGLE
        return mb.coe_header(CoeService.SDO_RESPONSE) + bytes([reply]) + seg

    def _download_initiate(
        self, command: int, index: int, subindex: int, body: bytes, state: int
    ) -> bytes:
        ca = bool(command & mb.SDO_COMPLETE_ACCESS)
        at = mb.COE_HEADER_BYTES + 4
        if command & mb.SDO_EXPEDITED:
            size = 4 - (command >> 2 & 0x03) if command & mb.SDO_SIZE_INDICATED else 4
            return self._store(index, subindex, ca, body[at : at + size], state)
        if not command & mb.SDO_SIZE_INDICATED:
            return self._abort(index, subindex, SdoAbort.UNKNOWN_COMMAND)
        (size,) = _U32.unpack_from(body, at)
        data = body[at + 4 :]
        if len(data) >= size:
            return self._store(index, subindex, ca, data[:size], state)
        self._download = _Transfer(index, subindex, ca, bytearray(data), size)
        command = mb.SCS_DOWNLOAD_INITIATE << 5 | (mb.SDO_COMPLETE_ACCESS if ca else 0)
        return self._response(command, index, subindex, bytes(4))

    def _download_segment(self, command: int, body: bytes, state: int) -> bytes:
        t = self._download
        refused = self._segment_check(t, command)
        if refused is not None or t is None:
            return refused or b""
        toggle = command & mb.SDO_TOGGLE
        seg = body[SEGMENT_HEADER_BYTES:]
        if len(seg) == MIN_SEGMENT_DATA:  # bits 3-1: bytes of the 7 without data
            seg = seg[: MIN_SEGMENT_DATA - (command >> 1 & 0x07)]
        t.data += seg
        t.toggle ^= mb.SDO_TOGGLE
        if not command & mb.SDO_LAST_SEGMENT:
            if len(t.data) > t.size:
                self._download = None
                return self._abort(t.index, t.subindex, SdoAbort.LENGTH_MISMATCH)
            return (
                mb.coe_header(CoeService.SDO_RESPONSE)
                + bytes([mb.SCS_DOWNLOAD_SEGMENT << 5 | toggle])
                + bytes(MIN_SEGMENT_DATA)
            )
        self._download = None
        if len(t.data) != t.size:
            return self._abort(t.index, t.subindex, SdoAbort.LENGTH_MISMATCH)
        code = self._write(t.index, t.subindex, t.complete_access, bytes(t.data), state)
        if code is not None:
            return self._abort(t.index, t.subindex, code)
        return (
            mb.coe_header(CoeService.SDO_RESPONSE)
            + bytes([mb.SCS_DOWNLOAD_SEGMENT << 5 | toggle])
            + bytes(MIN_SEGMENT_DATA)
        )

    def _write(self, index: int, subindex: int, ca: bool, data: bytes, state: int) -> int | None:
        if ca:
            return self.od.write_complete(index, subindex, data, state)
        return self.od.write(index, subindex, data, state)

    def _store(self, index: int, subindex: int, ca: bool, data: bytes, state: int) -> bytes:
        code = self._write(index, subindex, ca, data, state)
        if code is not None:
            return self._abort(index, subindex, code)
        command = mb.SCS_DOWNLOAD_INITIATE << 5 | (mb.SDO_COMPLETE_ACCESS if ca else 0)
        return self._response(command, index, subindex, bytes(4))

    # --- SDO information --------------------------------------------------------------------
    def _info(self, body: bytes) -> list[bytes]:
        at = mb.COE_HEADER_BYTES + mb.SDO_INFO_HEADER_BYTES
        if len(body) < at + 2:
            return []
        opcode = body[mb.COE_HEADER_BYTES] & 0x7F
        (word,) = struct.unpack_from("<H", body, at)
        if opcode == SdoInfoOpcode.OD_LIST_REQUEST:
            return self._od_list(word)
        if opcode == SdoInfoOpcode.OBJECT_DESCRIPTION_REQUEST:
            return [self._object_description(word)]
        if opcode == SdoInfoOpcode.ENTRY_DESCRIPTION_REQUEST and len(body) >= at + 4:
            return [self._entry_description(word, body[at + 2], body[at + 3])]
        return [self._info_error(SdoAbort.UNKNOWN_COMMAND)]

    @staticmethod
    def _info_error(code: int) -> bytes:
        return mb.sdo_info_header(SdoInfoOpcode.ERROR_REQUEST) + _U32.pack(code)

    def _lists(self) -> dict[int, list[int]]:
        objs = self.od.objects.values()

        def mappable(bit: int) -> list[int]:
            return [o.index for o in objs if any(e.access & bit for e in o.entries)]

        return {
            LIST_ALL: [o.index for o in objs],
            LIST_RXPDO: mappable(RXPDO_MAPPABLE),
            LIST_TXPDO: mappable(TXPDO_MAPPABLE),
            LIST_BACKUP: [],
            LIST_STARTUP: [],
        }

    def _od_list(self, list_type: int) -> list[bytes]:
        lists = self._lists()
        if list_type == LIST_LENGTHS:
            words = [len(lists[k]) for k in range(LIST_ALL, LIST_STARTUP + 1)]
        elif list_type in lists:
            words = lists[list_type]
        else:
            return [self._info_error(SdoAbort.VALUE_RANGE)]
        payload = struct.pack(f"<{len(words) + 1}H", list_type, *words)
        room = (self.room - mb.COE_HEADER_BYTES - mb.SDO_INFO_HEADER_BYTES) // 2 * 2
        chunks = [payload[k : k + room] for k in range(0, len(payload), room)]
        return [
            mb.sdo_info_header(
                SdoInfoOpcode.OD_LIST_RESPONSE, len(chunks) - 1 - k, incomplete=k < len(chunks) - 1
            )
            + chunk
            for k, chunk in enumerate(chunks)
        ]

    def _object_description(self, index: int) -> bytes:
        obj = self.od.objects.get(index)
        if obj is None:
            return self._info_error(SdoAbort.NO_OBJECT)
        return (
            mb.sdo_info_header(SdoInfoOpcode.OBJECT_DESCRIPTION_RESPONSE)
            + struct.pack("<HHBB", index, obj.data_type, obj.max_subindex, obj.code)
            + obj.name.encode("utf-8")
        )

    def _entry_description(self, index: int, subindex: int, value_info: int) -> bytes:
        e = self.od.description(index, subindex)
        if isinstance(e, int):
            return self._info_error(e)
        # access rights, object category and PDO mapping are always in the access word; unit,
        # default, minimum and maximum (bits 3-6) are not offered, so the reply clears them
        return (
            mb.sdo_info_header(SdoInfoOpcode.ENTRY_DESCRIPTION_RESPONSE)
            + struct.pack(
                "<HBBHHH", index, subindex, value_info & 0x07, e.data_type, e.bit_length, e.access
            )
            + e.name.encode("utf-8")
        )
