"""SDO abort codes: CiA 301's, which CoE (ETG.1000.6 Table 41) and POWERLINK (EPSG DS 301
6.3.2.4.2.3, Table 58) both take over; one enum for both, each protocol's own names kept
(a second name of the same code is an alias, ``SdoAbort.CANNOT_STORE is
SdoAbort.CANNOT_TRANSFER``)."""

from __future__ import annotations

from enum import IntEnum

__all__ = ["SdoAbort"]


class SdoAbort(IntEnum):
    """SDO abort codes (CiA 301 Table 22; ETG.1000.6 Table 41; DS 301 Table 58)."""

    TOGGLE_BIT = 0x05030000
    TIMEOUT = 0x05040000
    UNKNOWN_COMMAND = 0x05040001  # client/server command specifier not valid or unknown
    INVALID_BLOCK_SIZE = 0x05040002
    INVALID_SEQUENCE = 0x05040003  # (block mode; DS 301)
    CRC_ERROR = 0x05040004  # (block mode; DS 301)
    OUT_OF_MEMORY = 0x05040005
    UNSUPPORTED_ACCESS = 0x06010000
    WRITE_ONLY = 0x06010001  # "attempt to read a write only object"
    READ_ONLY = 0x06010002  # "attempt to write a read only object"
    SUBINDEX0_NOT_ZERO = 0x06010003  # "subindex 0 must be 0 for write access" (CoE)
    COMPLETE_ACCESS_UNSUPPORTED = 0x06010004  # (CoE)
    NO_OBJECT = 0x06020000
    NOT_MAPPABLE = 0x06040041
    PDO_TOO_LONG = 0x06040042  # number and length of mapped objects exceed the PDO length
    INCOMPATIBLE_PARAMETER = 0x06040043
    INTERNAL_INCOMPATIBILITY = 0x06040047
    HARDWARE_ERROR = 0x06060000
    LENGTH_MISMATCH = 0x06070010
    LENGTH_TOO_HIGH = 0x06070012
    LENGTH_TOO_LOW = 0x06070013
    NO_SUBINDEX = 0x06090011
    VALUE_RANGE = 0x06090030
    VALUE_TOO_HIGH = 0x06090031
    VALUE_TOO_LOW = 0x06090032
    GENERAL_ERROR = 0x08000000
    CANNOT_TRANSFER = 0x08000020  # "data cannot be transferred or stored"
    LOCAL_CONTROL = 0x08000021
    DEVICE_STATE = 0x08000022  # "because of the present device state"
    NO_DICTIONARY = 0x08000023
    CONNECTION_INVALID = 0x08000024  # EPL: the connection is not established (Table 58)
    # the names POWERLINK's code in this project gave them (aliases)
    READ_WRITE_ONLY = 0x06010001
    WRITE_READ_ONLY = 0x06010002
    PARAMETER_INCOMPATIBLE = 0x06040043
    INTERNAL_INCOMPATIBLE = 0x06040047
    CANNOT_STORE = 0x08000020
