"""The SDO layers over ASnd as numbers and headers (EPSG DS 301 V1.4.0 6.3.2).

:class:`~skinframes.powerlink.services.Sdo` and :class:`~skinframes.powerlink.services.SdoCommand`
carry the sequence layer (6.3.2.3) and the command layer header (6.3.2.4.1); this module names
their codes and reads and writes what the command layer's data starts with:

- :class:`SequenceCon`: the connection states of ``receive_con``/``send_con`` (Tables 51-52).
- :class:`CommandId` and :class:`Segmentation`: the command layer's CommandID and segmentation
  (6.3.2.4.1, Table 55).
- :class:`AbortCode`: the SDO abort codes (6.3.2.4.2.3, Table 58), the data of an aborted
  transfer (one UNSIGNED32).
- :func:`pack_index` / :func:`unpack_index`: the 4-byte Index, SubIndex, reserved head of a
  WriteByIndex/ReadByIndex request (6.3.2.4.2.1.1, .2); a segmented transfer's first segment
  puts the 4-byte DataSize before it (6.3.2.4.1, "Data size": :func:`pack_data_size`).

Sequence numbers are 6 bits and count modulo 64 (6.3.2.3.1): :func:`seq_add`, :func:`seq_diff`.
"""

from __future__ import annotations

import struct
from enum import IntEnum
from typing import Final

from skinframes.errors import FieldRangeError, TruncatedError
from skinframes.sdo_abort import SdoAbort

SEQUENCE_MODULO: Final = 64  # 6-bit sequence numbers (DS 301 6.3.2.3.1)
INDEX_HEADER_BYTES: Final = 4  # Index u16, SubIndex u8, reserved u8 (6.3.2.4.2.1.1)
DATA_SIZE_BYTES: Final = 4  # DataSize u32 of an initiate segment (6.3.2.4.1)
ABORT_CODE_BYTES: Final = 4
# The largest command layer segment one ASnd carries: the async MTU (C_DLL_MAX_ASYNC_MTU 1500,
# DS 301 4.6.1.1.6: ASnd payload at most 1500 - header) less the ASnd header (4), the sequence
# layer (4) and the command layer header (8); openPOWERLINK's SDO_MAX_SEGMENT_SIZE is the same.
MAX_ASYNC_MTU_BYTES: Final = 1500
MAX_SEGMENT_BYTES: Final = MAX_ASYNC_MTU_BYTES - 4 - 4 - 8

_INDEX: Final = struct.Struct("<HBB")
_U32: Final = struct.Struct("<I")


class SequenceCon(IntEnum):
    """ReceiveCon / SendCon (DS 301 6.3.2.3, Tables 51 and 52)."""

    NO_CONNECTION = 0
    INITIALIZATION = 1
    CONNECTION_VALID = 2
    ERROR_OR_ACK_REQUEST = 3  # rcon: error response (retransmit); scon: ack request


class CommandId(IntEnum):
    """CommandID of the command layer (DS 301 6.3.2.4.1, Table 55), a selection."""

    NIL = 0x00
    WRITE_BY_INDEX = 0x01
    READ_BY_INDEX = 0x02
    WRITE_ALL_BY_INDEX = 0x03
    READ_ALL_BY_INDEX = 0x04
    WRITE_BY_NAME = 0x05
    READ_BY_NAME = 0x06
    FILE_WRITE = 0x20
    FILE_READ = 0x21
    WRITE_MULTIPLE_PARAM_BY_INDEX = 0x31
    READ_MULTIPLE_PARAM_BY_INDEX = 0x32
    MAX_SEGMENT_SIZE = 0x70


class Segmentation(IntEnum):
    """Segmentation bits 4-5 of the command layer flags (DS 301 6.3.2.4.1)."""

    EXPEDITED = 0
    INITIATE = 1
    SEGMENT = 2
    COMPLETE = 3


AbortCode = SdoAbort  # DS 301 6.3.2.4.2.3, Table 58: CiA 301's codes (skinframes.sdo_abort)


def pack_index(index: int, subindex: int) -> bytes:
    """The 4-byte Index, SubIndex, reserved head of a by-index request (DS 301 6.3.2.4.2.1)."""
    try:
        return _INDEX.pack(index, subindex, 0)
    except struct.error as exc:
        raise FieldRangeError(f"EPL SDO: index {index:#x}/{subindex} does not fit") from exc


def unpack_index(data: bytes) -> tuple[int, int, bytes]:
    """Index, SubIndex and the bytes after the 4-byte head (the reserved byte is ignored).

    Raises:
        TruncatedError: fewer than 4 bytes.
    """
    if len(data) < INDEX_HEADER_BYTES:
        raise TruncatedError(
            f"EPL SDO: {len(data)} command data bytes, Index and SubIndex need {INDEX_HEADER_BYTES}",
            field="index",
        )
    index, subindex, _ = _INDEX.unpack_from(data)
    return index, subindex, bytes(data[INDEX_HEADER_BYTES:])


def pack_data_size(size_bytes: int) -> bytes:
    """The DataSize (u32) that opens an initiate segment (DS 301 6.3.2.4.1)."""
    try:
        return _U32.pack(size_bytes)
    except struct.error as exc:
        raise FieldRangeError(f"EPL SDO: data size {size_bytes} does not fit 32 bits") from exc


def unpack_data_size(data: bytes) -> tuple[int, bytes]:
    """DataSize of an initiate segment and the bytes after it.

    Raises:
        TruncatedError: fewer than 4 bytes.
    """
    if len(data) < DATA_SIZE_BYTES:
        raise TruncatedError(
            f"EPL SDO: {len(data)} bytes, an initiate segment's DataSize needs {DATA_SIZE_BYTES}",
            field="data_size",
        )
    return _U32.unpack_from(data)[0], bytes(data[DATA_SIZE_BYTES:])


def abort_data(code: int) -> bytes:
    """The data of an aborted transfer: the abort code, UNSIGNED32 (DS 301 6.3.2.4.2.3)."""
    try:
        return _U32.pack(code)
    except struct.error as exc:
        raise FieldRangeError(f"EPL SDO: abort code {code} does not fit 32 bits") from exc


def seq_add(number: int, step: int = 1) -> int:
    """``number + step`` modulo 64 (6-bit sequence numbers)."""
    return (number + step) % SEQUENCE_MODULO


def seq_diff(later: int, earlier: int) -> int:
    """How far ``later`` is ahead of ``earlier``, 0..63 (modulo 64)."""
    return (later - earlier) % SEQUENCE_MODULO
