"""EtherCAT mailbox and CANopen over EtherCAT (CoE) bytes.

* the mailbox header (ETG.1000.4 5.6 / ETG.1000.6 5.6.1, Table 29): length u16 (bytes after the
  6-byte header), address u16, one byte channel (bits 0-5) and priority (bits 6-7), one byte
  type (bits 0-3) and counter (bits 4-6, 1..7; 0 = the sender does not count);
* the mailbox error reply (type 0, ETG.1000.6 5.6.2): command u16 = 1, detail u16;
* the CoE header (ETG.1000.6 5.6.2, Table 35): one word, number bits 0-8, service bits 12-15;
* the SDO command byte (ETG.1000.6 5.6.2.x, CiA 301 7.2.4.3 plus CoE's complete-access bit 4)
  and the SDO header that follows it (index u16, subindex u8, 4 data bytes);
* the SDO information header (ETG.1000.6 5.6.3, Table 43): opcode bits 0-6, incomplete bit 7,
  a reserved byte, fragments left u16;
* the emergency message (ETG.1000.6 5.6.4): error code u16, error register u8, 5 data bytes;
* SDO abort codes (ETG.1000.6 Table 41).

Wireshark's ``packet-ecatmb.c`` decodes the same layouts (fields ``ecat_mailbox.*``); the tests
compare with it. Everything little-endian.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import IntEnum
from typing import Final

from skinframes.errors import FieldRangeError, TruncatedError
from skinframes.sdo_abort import SdoAbort

__all__ = [
    "COE_HEADER_BYTES",
    "MAILBOX_HEADER_BYTES",
    "SDO_HEADER_BYTES",
    "SDO_INFO_HEADER_BYTES",
    "CoeService",
    "MailboxErrorCode",
    "MailboxHeader",
    "MailboxType",
    "SdoAbort",
    "SdoInfoOpcode",
    "coe_header",
    "emergency",
    "mailbox",
    "mailbox_error",
    "next_counter",
    "parse_coe_header",
    "sdo_abort",
    "sdo_download_expedited",
    "sdo_info_header",
    "sdo_upload_request",
]

MAILBOX_HEADER_BYTES: Final = 6
COE_HEADER_BYTES: Final = 2
SDO_HEADER_BYTES: Final = 8  # command, index, subindex, 4 data (or size) bytes
SDO_INFO_HEADER_BYTES: Final = 4  # opcode, reserved, fragments left
EMERGENCY_BYTES: Final = 8
MAX_COUNTER: Final = 7

# SDO command specifiers (ETG.1000.6 5.6.2.1-5.6.2.9; CiA 301 7.2.4.3)
CCS_DOWNLOAD_SEGMENT: Final = 0
CCS_DOWNLOAD_INITIATE: Final = 1
CCS_UPLOAD_INITIATE: Final = 2
CCS_UPLOAD_SEGMENT: Final = 3
CS_ABORT: Final = 4
SCS_UPLOAD_SEGMENT: Final = 0
SCS_DOWNLOAD_SEGMENT: Final = 1
SCS_UPLOAD_INITIATE: Final = 2
SCS_DOWNLOAD_INITIATE: Final = 3
SDO_SIZE_INDICATED: Final = 0x01
SDO_EXPEDITED: Final = 0x02
SDO_COMPLETE_ACCESS: Final = 0x10
SDO_TOGGLE: Final = 0x10
SDO_LAST_SEGMENT: Final = 0x01
SDO_INFO_INCOMPLETE: Final = 0x80


class MailboxType(IntEnum):
    """Mailbox header type (ETG.1000.4 Table 29); equals ``tshark -G values`` for
    ecat_mailbox.type."""

    ERROR = 0x0
    AOE = 0x1
    EOE = 0x2
    COE = 0x3
    FOE = 0x4
    SOE = 0x5
    VOE = 0xF


class MailboxErrorCode(IntEnum):
    """Detail of a mailbox error reply (ETG.1000.6 Table 30)."""

    SYNTAX = 0x0001
    UNSUPPORTED_PROTOCOL = 0x0002
    INVALID_CHANNEL = 0x0003
    SERVICE_NOT_SUPPORTED = 0x0004
    INVALID_HEADER = 0x0005
    SIZE_TOO_SHORT = 0x0006
    NO_MORE_MEMORY = 0x0007
    INVALID_SIZE = 0x0008


class CoeService(IntEnum):
    """CoE header service, bits 12-15 (ETG.1000.6 Table 35)."""

    EMERGENCY = 0x1
    SDO_REQUEST = 0x2
    SDO_RESPONSE = 0x3
    TXPDO = 0x4
    RXPDO = 0x5
    TXPDO_REMOTE_REQUEST = 0x6
    RXPDO_REMOTE_REQUEST = 0x7
    SDO_INFORMATION = 0x8


class SdoInfoOpcode(IntEnum):
    """SDO information opcode (ETG.1000.6 Table 44)."""

    OD_LIST_REQUEST = 0x01
    OD_LIST_RESPONSE = 0x02
    OBJECT_DESCRIPTION_REQUEST = 0x03
    OBJECT_DESCRIPTION_RESPONSE = 0x04
    ENTRY_DESCRIPTION_REQUEST = 0x05
    ENTRY_DESCRIPTION_RESPONSE = 0x06
    ERROR_REQUEST = 0x07


# SdoAbort: CiA 301's codes, one enum with POWERLINK's (skinframes.sdo_abort), imported above


_HEADER = struct.Struct("<HHBB")
_U16 = struct.Struct("<H")
_SDO = struct.Struct("<BHB")


@dataclass(frozen=True, slots=True)
class MailboxHeader:
    """The 6-byte mailbox header (ETG.1000.4 Table 29)."""

    length: int
    type: int
    counter: int = 0
    address: int = 0
    channel: int = 0
    priority: int = 0

    def to_bytes(self) -> bytes:
        """Encode; every field is range-checked."""
        for name, value, bits in (
            ("length", self.length, 16),
            ("address", self.address, 16),
            ("channel", self.channel, 6),
            ("priority", self.priority, 2),
            ("type", self.type, 4),
            ("counter", self.counter, 3),
        ):
            if not 0 <= value < 1 << bits:
                raise FieldRangeError(f"mailbox header: {name} {value} does not fit {bits} bits")
        return _HEADER.pack(
            self.length,
            self.address,
            self.channel | self.priority << 6,
            self.type | self.counter << 4,
        )

    @classmethod
    def from_bytes(cls, buf: bytes) -> MailboxHeader:
        """Decode the first 6 bytes of ``buf`` (bit 7 of the type byte is reserved, ignored)."""
        if len(buf) < MAILBOX_HEADER_BYTES:
            raise TruncatedError(f"mailbox header: {len(buf)} of {MAILBOX_HEADER_BYTES} bytes")
        length, address, cp, tc = _HEADER.unpack_from(buf)
        return cls(length, tc & 0x0F, (tc >> 4) & 0x07, address, cp & 0x3F, cp >> 6)


def next_counter(counter: int) -> int:
    """The mailbox counter after ``counter``: 1, 2, ..., 7, 1, ... (0 is never used again)."""
    return counter % MAX_COUNTER + 1


def mailbox(
    kind: int, body: bytes, counter: int = 0, *, size: int | None = None, address: int = 0
) -> bytes:
    """A mailbox message: header + ``body``, padded with zeros to ``size`` bytes when given
    (a master writes the whole SyncManager buffer, so that the ESC sees its end address)."""
    out = MailboxHeader(len(body), kind, counter, address).to_bytes() + body
    if size is not None:
        if len(out) > size:
            raise FieldRangeError(f"mailbox: {len(out)} bytes do not fit a {size}-byte mailbox")
        out += bytes(size - len(out))
    return out


def mailbox_error(detail: int) -> bytes:
    """The body of a mailbox error reply (type 0): command 0x0001, ``detail``."""
    return struct.pack("<HH", 0x0001, detail)


def coe_header(service: int, number: int = 0) -> bytes:
    """The CoE header word: PDO number (or 0) in bits 0-8, ``service`` in bits 12-15."""
    if not 0 <= number < 1 << 9 or not 0 <= service < 16:
        raise FieldRangeError(f"CoE header: number {number} / service {service} out of range")
    return _U16.pack(number | service << 12)


def parse_coe_header(buf: bytes) -> tuple[int, int]:
    """(number, service) of the CoE header at the start of ``buf``."""
    if len(buf) < COE_HEADER_BYTES:
        raise TruncatedError("CoE header: fewer than 2 bytes")
    (word,) = _U16.unpack_from(buf)
    return word & 0x01FF, word >> 12


def sdo_upload_request(index: int, subindex: int, *, complete_access: bool = False) -> bytes:
    """CoE body of an SDO upload initiate request (ETG.1000.6 5.6.2.4.1)."""
    command = CCS_UPLOAD_INITIATE << 5 | (SDO_COMPLETE_ACCESS if complete_access else 0)
    return coe_header(CoeService.SDO_REQUEST) + _SDO.pack(command, index, subindex) + bytes(4)


def sdo_download_expedited(index: int, subindex: int, data: bytes) -> bytes:
    """CoE body of an expedited SDO download request, 1-4 data bytes (ETG.1000.6 5.6.2.1.1)."""
    if not 1 <= len(data) <= 4:
        raise FieldRangeError(f"expedited SDO download: {len(data)} bytes (1..4)")
    command = CCS_DOWNLOAD_INITIATE << 5 | (4 - len(data)) << 2 | SDO_EXPEDITED | SDO_SIZE_INDICATED
    return (
        coe_header(CoeService.SDO_REQUEST)
        + _SDO.pack(command, index, subindex)
        + data
        + bytes(4 - len(data))
    )


def sdo_abort(
    index: int, subindex: int, code: int, *, service: int = CoeService.SDO_REQUEST
) -> bytes:
    """CoE body of an abort SDO transfer (ETG.1000.6 5.6.2.7), from master or slave."""
    return coe_header(service) + _SDO.pack(CS_ABORT << 5, index, subindex) + struct.pack("<I", code)


def sdo_info_header(opcode: int, fragments_left: int = 0, *, incomplete: bool = False) -> bytes:
    """CoE header (service 8) and the SDO information header (ETG.1000.6 Table 43)."""
    return coe_header(CoeService.SDO_INFORMATION) + struct.pack(
        "<BBH", opcode | (SDO_INFO_INCOMPLETE if incomplete else 0), 0, fragments_left
    )


def emergency(error_code: int, error_register: int, data: bytes = b"") -> bytes:
    """CoE body of an emergency message (ETG.1000.6 5.6.4): code, register, 5 data bytes."""
    if len(data) > 5:
        raise FieldRangeError(f"emergency: {len(data)} data bytes (at most 5)")
    return (
        coe_header(CoeService.EMERGENCY)
        + struct.pack("<HB", error_code, error_register)
        + data
        + bytes(5 - len(data))
    )
