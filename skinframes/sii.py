"""The Slave Information Interface (SII) EEPROM image of an EtherCAT slave: encode and decode.

Layout: ETG.1000.6 clause 5.4 and ETG.2010 (SII specification), as the Beckhoff ESC datasheet
section I, 11.1 (Tables 42 and 43) summarises it. The EEPROM is word addressed, little-endian:

* words 0-6: ESC configuration area (PDI control and configuration, SYNC pulse length,
  extended PDI configuration, configured station alias, two reserved words); word 7, the
  checksum: the low byte is the CRC-8 of bytes 0-13 with polynomial x^8 + x^2 + x + 1 (0x07),
  initial value 0xFF, no reflection, no final XOR (datasheet I, Table 42); high byte 0;
* words 8-15: vendor ID, product code, revision number, serial number (u32 each);
* words 0x14-0x17: bootstrap receive/send mailbox offset and size; words 0x18-0x1B: standard
  receive mailbox (master -> slave) and send mailbox offset and size; word 0x1C: the mailbox
  protocols (ETG.2010 Table 2: bit 0 AoE, 1 EoE, 2 CoE, 3 FoE, 4 SoE, 5 VoE);
* word 0x3E: EEPROM size in Kibit minus 1; word 0x3F: version (1);
* from word 0x40: categories ``{type u16, size in words u16, data}``, ended by type 0xFFFF
  (ETG.2010 Table 3): STRINGS (10), GENERAL (30), FMMU (40), SYNCM (41), TXPDO (50),
  RXPDO (51), DC (60); others are kept as raw bytes.

:class:`SiiImage` is the model, :func:`encode_sii` and :func:`decode_sii` the codec, and
:func:`sii_from_esi` builds the image an ESI device description (:mod:`skinframes.esi`) asks for.
The encoder writes the categories in the order above, each only when it has content.
"""

from __future__ import annotations

import dataclasses
import functools
import struct
from collections.abc import Callable
from dataclasses import dataclass
from enum import IntEnum
from typing import Final

from skinframes.errors import (
    FieldRangeError,
    InvalidFieldError,
    LengthMismatchError,
    TruncatedError,
)
from skinframes.esi import EsiDevice, EsiFile, EsiPdo
from skinframes.findings import Finding, error, info, warning

__all__ = [
    "CHECKSUM_BYPASS",
    "CONFIG_AREA_BYTES",
    "ESI_FMMU_USES",
    "ESI_SM_TYPES",
    "FIRST_CATEGORY_WORD",
    "HEADER_BYTES",
    "Category",
    "DecodedSii",
    "FmmuUsage",
    "MailboxProtocol",
    "SiiCategory",
    "SiiDc",
    "SiiFromEsi",
    "SiiGeneral",
    "SiiImage",
    "SiiPdo",
    "SiiPdoEntry",
    "SiiSyncManager",
    "SyncManagerType",
    "config_area",
    "crc8",
    "decode_sii",
    "encode_sii",
    "fit_eeprom",
    "image_from_esi",
    "sii_from_esi",
    "standard_eeprom_kibit",
    "stated_eeprom_kibit",
]

# --- constants (ETG.2010 Table 2; datasheet I, Tables 42/43) ---------------------------------
CONFIG_AREA_BYTES: Final = 14  # words 0-6, covered by the checksum in word 7
CHECKSUM_BYPASS: Final = 0x88A4  # datasheet I, Table 42: "disable the checksum validation"
FIRST_CATEGORY_WORD: Final = 0x40
HEADER_BYTES: Final = 2 * FIRST_CATEGORY_WORD  # 128
SII_VERSION: Final = 1
BYTES_PER_KIBIT: Final = 128
MIN_EEPROM_KIBIT: Final = 2  # datasheet I, 11: words 0-63 plus General need at least 2 Kibit
MAX_STRINGS: Final = 255  # string indices are one byte; 0 means "no string"
ERASED: Final = 0xFF  # an erased EEPROM byte, after the end category
_IDENTITY = struct.Struct("<IIII")  # words 8-15: vendor, product, revision, serial
_MAILBOXES = struct.Struct("<9H")  # words 0x14-0x1C: bootstrap, standard mailboxes, protocols
_TRAILER = struct.Struct("<HH")  # words 0x3E-0x3F: size, version
_SYNCM = struct.Struct("<HHBBBB")  # ETG.2010 Table 9: start, length, control, status, enable, type
_PDO = struct.Struct("<HBBBBH")  # Table 11: index, entries, SM, sync, name index, flags
_ENTRY = struct.Struct("<HBBBBH")  # Table 12: index, subindex, name index, type, bits, flags
_DC = struct.Struct("<IIIhHhBB4x")  # Table 14: cycle 0, shift 0, shift 1, factors, names
_GENERAL = struct.Struct("<BBBBBBBBBBBBhBBHH12x")  # Table 6: 32 bytes


class Category(IntEnum):
    """SII category types (ETG.2010 Table 3)."""

    NOP = 0
    STRINGS = 10
    DATATYPES = 20
    GENERAL = 30
    FMMU = 40
    SYNCM = 41
    TXPDO = 50
    RXPDO = 51
    DC = 60
    END = 0xFFFF


class MailboxProtocol(IntEnum):
    """SII word 0x1C: the mailbox protocols, one bit each (ETG.2010 Table 2)."""

    AOE = 0x0001
    EOE = 0x0002
    COE = 0x0004
    FOE = 0x0008
    SOE = 0x0010
    VOE = 0x0020


class FmmuUsage(IntEnum):
    """FMMU category: what each FMMU is meant for (ETG.2010 Table 8)."""

    UNUSED = 0x00
    OUTPUTS = 0x01
    INPUTS = 0x02
    SYNCM_STATUS = 0x03


class SyncManagerType(IntEnum):
    """SYNCM category byte 7 (ETG.2010 Table 9)."""

    UNUSED = 0x00
    MAILBOX_OUT = 0x01  # master -> slave mailbox
    MAILBOX_IN = 0x02  # slave -> master mailbox
    OUTPUTS = 0x03  # process data, master -> slave (RxPDO)
    INPUTS = 0x04  # process data, slave -> master (TxPDO)


# GENERAL byte 5, CoE details (ETG.2010 Table 6)
COE_SDO: Final = 0x01
COE_SDO_INFO: Final = 0x02
COE_PDO_ASSIGN: Final = 0x04
COE_PDO_CONFIG: Final = 0x08
COE_UPLOAD_AT_STARTUP: Final = 0x10
COE_COMPLETE_ACCESS: Final = 0x20
GENERAL_FLAG_MBOX_DATA_LINK_LAYER: Final = 0x04  # GENERAL byte 11, bit 2
# PDO flags (ETG.2010 Table 11): PdoMandatory from the ESI's Mandatory, PdoDefault from its Sm
# (assigned by default), PdoFixedContent from Fixed; checked against two independent SII tools'
# tables (synapticon's siitool decoder, ethercrab's PdoFlags), which agree on these values
PDO_MANDATORY: Final = 0x0001
PDO_DEFAULT: Final = 0x0002
PDO_FIXED_CONTENT: Final = 0x0010
PDO_NOT_ASSIGNED: Final = 0xFF  # the PDO's SyncManager byte when no SM is assigned
PORT_TYPES: Final = {"Y": 0x1, "H": 0x1, "K": 0x3}  # ESI Physics letter -> GENERAL port nibble
# ESI data type names -> CoE data type codes (ETG.1000.6 Table 64, ETG.1020)
DATA_TYPE_CODES: Final = {
    "BOOL": 0x01, "BIT": 0x01, "SINT": 0x02, "INT": 0x03, "DINT": 0x04, "USINT": 0x05,
    "UINT": 0x06, "UDINT": 0x07, "REAL": 0x08, "STRING": 0x09, "OCTET_STRING": 0x0A,
    "UNICODE_STRING": 0x0B, "TIME_OF_DAY": 0x0C, "TIME_DIFFERENCE": 0x0D, "DOMAIN": 0x0F,
    "INT24": 0x10, "LREAL": 0x11, "INT40": 0x12, "INT48": 0x13, "INT56": 0x14, "LINT": 0x15,
    "UINT24": 0x16, "UINT40": 0x18, "UINT48": 0x19, "UINT56": 0x1A, "ULINT": 0x1B,
    "BYTE": 0x1E, "WORD": 0x1F, "DWORD": 0x20, "BITARR8": 0x2D, "BITARR16": 0x2E,
    "BITARR32": 0x2F, "BIT1": 0x30, "BIT2": 0x31, "BIT3": 0x32, "BIT4": 0x33, "BIT5": 0x34,
    "BIT6": 0x35, "BIT7": 0x36, "BIT8": 0x37,
}  # fmt: skip


@functools.lru_cache(maxsize=256)
def crc8(data: bytes) -> int:
    """CRC-8 of the ESC configuration area: polynomial 0x07, initial value 0xFF, MSB first.

    Datasheet I, Table 42 (word 7): "remainder of division of word 0 to word 6 as unsigned
    number divided by the polynomial x^8+x^2+x+1 (initial value 0xFF)". Remembered for the
    last 256 areas: a broadcast EEPROM reload checks the same 14 bytes at every ESC.
    """
    crc = 0xFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


def standard_eeprom_kibit(image_bytes: int) -> int:
    """The smallest standard EEPROM (a power of two, at least 2 Kibit) that holds the image."""
    kibit = MIN_EEPROM_KIBIT
    while kibit * BYTES_PER_KIBIT < image_bytes:
        kibit *= 2
    return kibit


_CONFIG_WORDS = struct.Struct("<8H")  # words 0-7: ESC configuration area A and its checksum


def config_area(data: bytes | bytearray) -> tuple[int, ...] | None:
    """The ESC configuration area A of an SII image, words 0-7 (datasheet I 11.1, Table 42), as
    an ESC loads it: None when its checksum is wrong (word 7's low byte, the CRC-8 of words 0-6,
    unless word 7 is the bypass value :data:`CHECKSUM_BYPASS`)."""
    words: tuple[int, ...] = _CONFIG_WORDS.unpack_from(data)
    if words[7] == CHECKSUM_BYPASS or words[7] & 0xFF == crc8(bytes(data[:CONFIG_AREA_BYTES])):
        return words
    return None


def stated_eeprom_kibit(data: bytes | bytearray) -> int:
    """The EEPROM size an SII image states in word 0x3E (ETG.2010 Table 2: Kibit minus 1), in
    Kibit; ``data`` holds at least words 0-0x3F."""
    return int(_TRAILER.unpack_from(data, 2 * 0x3E)[0]) + 1


# --- the model ---------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class SiiGeneral:
    """The GENERAL category (ETG.2010 Table 6): string indices, mailbox details, ports.

    ``physical_ports`` holds 4 bits per port (0 unused, 1 MII, 3 EBUS, 4 fast hot connect).
    """

    group_index: int = 0
    image_index: int = 0
    order_index: int = 0
    name_index: int = 0
    coe_details: int = 0
    foe_details: int = 0
    eoe_details: int = 0
    soe_channels: int = 0
    ds402_channels: int = 0
    sysman_class: int = 0
    flags: int = 0
    current_on_ebus_ma: int = 0
    physical_ports: int = 0
    physical_memory_address: int = 0
    reserved_byte_4: int = 0  # SOES's tools write a value here; kept so images re-encode


@dataclass(frozen=True, slots=True)
class SiiSyncManager:
    """One SYNCM entry (ETG.2010 Table 9): what a master programs into 0x0800 + 8 n."""

    start: int
    length: int
    control: int
    enable: int
    type: SyncManagerType
    status: int = 0


@dataclass(frozen=True, slots=True)
class SiiPdoEntry:
    """One PDO entry (ETG.2010 Table 12); ``data_type`` is the CoE code (low byte)."""

    index: int
    subindex: int
    bit_length: int
    data_type: int = 0
    name_index: int = 0
    flags: int = 0


@dataclass(frozen=True, slots=True)
class SiiPdo:
    """One PDO of a TXPDO/RXPDO category (ETG.2010 Table 11).

    ``sync_manager`` 0xFF: not assigned to any SyncManager.
    """

    index: int
    sync_manager: int
    entries: tuple[SiiPdoEntry, ...]
    synchronization: int = 0
    name_index: int = 0
    flags: int = 0


@dataclass(frozen=True, slots=True)
class SiiDc:
    """One entry of the DC category (ETG.2010 Table 14): an op mode; times in nanoseconds."""

    cycle_time_0_ns: int = 0
    shift_time_0_ns: int = 0
    shift_time_1_ns: int = 0
    sync1_cycle_factor: int = 0
    assign_activate: int = 0
    sync0_cycle_factor: int = 0
    name_index: int = 0
    description_index: int = 0


@dataclass(frozen=True, slots=True)
class SiiCategory:
    """A category this module does not model, kept as its type and data bytes."""

    category_type: int
    data: bytes


@dataclass(frozen=True, slots=True)
class SiiImage:
    """A whole SII image: the header words and the categories.

    ``config_data`` are the 14 bytes of words 0-6 (the checksum in word 7 is computed);
    ``eeprom_bytes`` is the EEPROM size (a multiple of 128; word 0x3E holds it in Kibit - 1,
    and the encoded image is padded with 0xFF to it). Mailboxes are (offset, size in bytes).
    ``strings`` are 1-based in the image: index 0 means "no string".
    """

    config_data: bytes
    vendor_id: int
    product_code: int
    revision: int
    serial: int
    eeprom_bytes: int
    bootstrap_rx_mailbox: tuple[int, int] = (0, 0)
    bootstrap_tx_mailbox: tuple[int, int] = (0, 0)
    standard_rx_mailbox: tuple[int, int] = (0, 0)
    standard_tx_mailbox: tuple[int, int] = (0, 0)
    mailbox_protocols: int = 0
    version: int = SII_VERSION
    strings: tuple[str, ...] = ()
    general: SiiGeneral | None = None
    fmmus: tuple[int, ...] = ()
    sync_managers: tuple[SiiSyncManager, ...] = ()
    tx_pdos: tuple[SiiPdo, ...] = ()
    rx_pdos: tuple[SiiPdo, ...] = ()
    dc: tuple[SiiDc, ...] = ()
    other_categories: tuple[SiiCategory, ...] = ()

    @property
    def alias(self) -> int:
        """The configured station alias, word 4."""
        return int.from_bytes(self.config_data[8:10], "little")

    def string(self, index: int) -> str:
        """String ``index`` (1-based); ``""`` for 0 or an index past the table."""
        return self.strings[index - 1] if 0 < index <= len(self.strings) else ""


# --- encoding ----------------------------------------------------------------------------------
def _check(label: str, value: int, bits: int, signed: bool = False) -> None:
    low, high = (-(1 << (bits - 1)), 1 << (bits - 1)) if signed else (0, 1 << bits)
    if not low <= value < high:
        raise FieldRangeError(f"SII: {label} {value} does not fit {bits} bits", field=label)


def _category(kind: int, data: bytes) -> bytes:
    if len(data) % 2:
        data += b"\x00"  # categories are whole words
    _check(f"category {kind} size in words", len(data) // 2, 16)
    return struct.pack("<HH", kind, len(data) // 2) + data


def _pack(what: str, layout: struct.Struct, *values: int) -> bytes:
    try:
        return layout.pack(*values)
    except struct.error as exc:
        raise FieldRangeError(f"SII: {what}: a value does not fit its field ({exc})") from exc


def _pdos(pdos: tuple[SiiPdo, ...], what: str) -> bytes:
    out = bytearray()
    for p in pdos:
        _check(f"{what} {p.index:#06x} entries", len(p.entries), 8)
        out += _pack(
            f"{what} {p.index:#x}",
            _PDO,
            p.index,
            len(p.entries),
            p.sync_manager,
            p.synchronization,
            p.name_index,
            p.flags,
        )
        for e in p.entries:
            out += _pack(
                f"{what} {p.index:#x} entry {e.index:#x}:{e.subindex}",
                _ENTRY,
                e.index,
                e.subindex,
                e.name_index,
                e.data_type,
                e.bit_length,
                e.flags,
            )
    return bytes(out)


def encode_sii(image: SiiImage) -> bytes:
    """The bytes of ``image``, padded with 0xFF to ``image.eeprom_bytes``.

    Raises:
        FieldRangeError: a value does not fit its field, more than 255 strings or a string
            longer than 255 bytes, or the image does not fit ``eeprom_bytes``.
    """
    content = _content(image)
    if len(content) > image.eeprom_bytes:
        raise FieldRangeError(
            f"SII: the image needs {len(content)} bytes, the EEPROM holds {image.eeprom_bytes}",
            field="eeprom_bytes",
        )
    return bytes(content) + bytes([ERASED]) * (image.eeprom_bytes - len(content))


def fit_eeprom(image: SiiImage) -> SiiImage:
    """``image`` with ``eeprom_bytes`` the smallest standard EEPROM (>= 2 Kibit) that holds it."""
    used = len(_content(dataclasses.replace(image, eeprom_bytes=BYTES_PER_KIBIT)))
    return dataclasses.replace(image, eeprom_bytes=standard_eeprom_kibit(used) * BYTES_PER_KIBIT)


def _content(image: SiiImage) -> bytearray:
    """The header and the categories up to the end marker, without the erased rest."""
    if len(image.config_data) != CONFIG_AREA_BYTES:
        raise FieldRangeError(
            f"SII: config_data is {len(image.config_data)} bytes, expected {CONFIG_AREA_BYTES}"
        )
    if image.eeprom_bytes % BYTES_PER_KIBIT or image.eeprom_bytes <= 0:
        raise FieldRangeError(f"SII: eeprom_bytes {image.eeprom_bytes} is not a multiple of 128")
    head = bytearray(HEADER_BYTES)
    head[:CONFIG_AREA_BYTES] = image.config_data
    head[CONFIG_AREA_BYTES] = crc8(bytes(image.config_data))
    head[16:32] = _pack(
        "identity", _IDENTITY, image.vendor_id, image.product_code, image.revision, image.serial
    )
    head[0x28:0x3A] = _pack(
        "mailbox words",
        _MAILBOXES,
        *image.bootstrap_rx_mailbox,
        *image.bootstrap_tx_mailbox,
        *image.standard_rx_mailbox,
        *image.standard_tx_mailbox,
        image.mailbox_protocols,
    )
    size_word = image.eeprom_bytes // BYTES_PER_KIBIT - 1
    head[0x7C:0x80] = _pack("size and version", _TRAILER, size_word, image.version)

    body = bytearray()
    if image.strings:
        _check("number of strings", len(image.strings), 8)
        table = bytearray([len(image.strings)])
        for s in image.strings:
            raw = s.encode("utf-8", "surrogateescape")
            _check(f"length of string {s!r}", len(raw), 8)
            table += bytes([len(raw)]) + raw
        body += _category(Category.STRINGS, bytes(table))
    if image.general is not None:
        g = image.general
        body += _category(
            Category.GENERAL,
            _pack(
                "GENERAL",
                _GENERAL,
                g.group_index,
                g.image_index,
                g.order_index,
                g.name_index,
                g.reserved_byte_4,
                g.coe_details,
                g.foe_details,
                g.eoe_details,
                g.soe_channels,
                g.ds402_channels,
                g.sysman_class,
                g.flags,
                g.current_on_ebus_ma,
                g.group_index,  # byte 14 repeats GroupIdx "for compatibility"
                0,
                g.physical_ports,
                g.physical_memory_address,
            ),
        )
    if image.fmmus:
        for f in image.fmmus:
            _check("FMMU usage", f, 8)
        body += _category(Category.FMMU, bytes(image.fmmus))
    if image.sync_managers:
        body += _category(
            Category.SYNCM,
            b"".join(
                _pack(
                    f"SyncManager {i}",
                    _SYNCM,
                    s.start,
                    s.length,
                    s.control,
                    s.status,
                    s.enable,
                    s.type,
                )
                for i, s in enumerate(image.sync_managers)
            ),
        )
    if image.tx_pdos:
        body += _category(Category.TXPDO, _pdos(image.tx_pdos, "TxPDO"))
    if image.rx_pdos:
        body += _category(Category.RXPDO, _pdos(image.rx_pdos, "RxPDO"))
    if image.dc:
        body += _category(
            Category.DC,
            b"".join(
                _pack(
                    f"DC op mode {i}",
                    _DC,
                    d.cycle_time_0_ns,
                    d.shift_time_0_ns,
                    d.shift_time_1_ns,
                    d.sync1_cycle_factor,
                    d.assign_activate,
                    d.sync0_cycle_factor,
                    d.name_index,
                    d.description_index,
                )
                for i, d in enumerate(image.dc)
            ),
        )
    for c in image.other_categories:
        _check("category type", c.category_type, 16)
        if c.category_type == Category.END:
            raise FieldRangeError(
                "SII: a category of type 0xFFFF (the end marker) in other_categories"
            )
        body += _category(c.category_type, c.data)
    body += struct.pack("<H", Category.END)
    return head + body


# --- decoding ----------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class DecodedSii:
    """What :func:`decode_sii` found: the image, and findings about it.

    ``findings`` reports a checksum that does not match (code ``sii.checksum``) or the word
    that disables its check (``sii.checksum_bypassed``, an INFO: an ESC accepts it), a version
    other than 1 (``sii.version``) and an image shorter than its size word says
    (``sii.short``); none of them stops decoding. ``end_offset`` is the byte after the end
    category.
    """

    image: SiiImage
    findings: tuple[Finding, ...]
    checksum: int
    end_offset: int


def _strings(data: bytes, offset: int) -> tuple[str, ...]:
    if not data:
        return ()
    count, pos, out = data[0], 1, []
    for i in range(count):
        if pos >= len(data):
            raise TruncatedError(
                f"SII STRINGS: string {i + 1} of {count} starts past the category's end",
                offset=offset + pos,
            )
        n = data[pos]
        if pos + 1 + n > len(data):
            raise TruncatedError(
                f"SII STRINGS: string {i + 1} of {n} bytes runs past the category's end",
                offset=offset + pos,
            )
        out.append(data[pos + 1 : pos + 1 + n].decode("utf-8", "surrogateescape"))
        pos += 1 + n
    return tuple(out)


def _records(data: bytes, layout: struct.Struct, what: str, offset: int) -> list[tuple[int, ...]]:
    if len(data) % layout.size:
        raise LengthMismatchError(
            f"SII {what}: {len(data)} bytes, not a multiple of {layout.size}", offset=offset
        )
    return [layout.unpack_from(data, i) for i in range(0, len(data), layout.size)]


def _pdo_list(data: bytes, what: str, offset: int) -> tuple[SiiPdo, ...]:
    pdos, pos = [], 0
    while pos < len(data):
        if pos + _PDO.size > len(data):
            if not data[pos:].strip(b"\x00"):
                break  # a pad byte
            raise TruncatedError(
                f"SII {what}: PDO header past the category's end", offset=offset + pos
            )
        index, n, sm, sync, name, flags = _PDO.unpack_from(data, pos)
        pos += _PDO.size
        if pos + n * _ENTRY.size > len(data):
            raise TruncatedError(
                f"SII {what}: PDO {index:#06x} has {n} entries, the category holds "
                f"{(len(data) - pos) // _ENTRY.size}",
                offset=offset + pos,
            )
        entries = []
        for _ in range(n):
            e_index, sub, e_name, dtype, bits, e_flags = _ENTRY.unpack_from(data, pos)
            entries.append(SiiPdoEntry(e_index, sub, bits, dtype, e_name, e_flags))
            pos += _ENTRY.size
        pdos.append(SiiPdo(index, sm, tuple(entries), sync, name, flags))
    return tuple(pdos)


def _enum(kind: type[SyncManagerType], value: int, what: str, offset: int) -> SyncManagerType:
    try:
        return kind(value)
    except ValueError:
        raise InvalidFieldError(f"SII {what}: type {value} unknown", offset=offset) from None


def decode_sii(data: bytes) -> DecodedSii:
    """Decode an SII image (an EEPROM dump or an image file).

    A checksum that does not match is a finding, not an error: dumps of real slaves with a
    stale checksum still decode; the bypass word 0x88A4 is an INFO finding, as an ESC loads
    the configuration area with it (:func:`config_area`). Bytes after the end category are not
    read.

    Raises:
        TruncatedError: fewer than 128 header bytes, a category running past the end of the
            data, or no end category.
        LengthMismatchError: a category whose size does not fit its records.
        InvalidFieldError: a SyncManager of unknown type.
    """
    data = bytes(data)
    if len(data) < HEADER_BYTES:
        raise TruncatedError(f"SII: {len(data)} bytes, the header alone is {HEADER_BYTES}")
    findings: list[Finding] = []
    config = data[:CONFIG_AREA_BYTES]
    checksum = int.from_bytes(data[14:16], "little")
    if checksum == CHECKSUM_BYPASS:  # an ESC loads words 0-6 unchecked (datasheet I Table 42)
        findings.append(
            info(
                "sii.checksum_bypassed",
                f"SII word 7: {CHECKSUM_BYPASS:#06x}, checksum validation disabled: an ESC "
                "loads words 0-6 without checking them",
            )
        )
    elif checksum & 0xFF != crc8(config):
        findings.append(
            error(
                "sii.checksum",
                f"SII word 7: checksum {checksum & 0xFF:#04x}, the CRC-8 of words 0-6 is "
                f"{crc8(config):#04x}",
            )
        )
    vendor, product, revision, serial = _IDENTITY.unpack_from(data, 16)
    words = _MAILBOXES.unpack_from(data, 0x28)
    size_word, version = _TRAILER.unpack_from(data, 0x7C)
    eeprom_bytes = (size_word + 1) * BYTES_PER_KIBIT
    if version != SII_VERSION:
        findings.append(warning("sii.version", f"SII word 0x3F: version {version}, expected 1"))
    fields: dict[str, object] = {}
    others: list[SiiCategory] = []
    pos = HEADER_BYTES
    while True:
        if pos + 2 > len(data):
            raise TruncatedError(
                f"SII: no end category (0xFFFF) before byte {len(data)}", offset=pos
            )
        kind = int.from_bytes(data[pos : pos + 2], "little")
        if kind == Category.END:
            pos += 2
            break
        if pos + 4 > len(data):
            raise TruncatedError(f"SII: category {kind} header runs past the end", offset=pos)
        size = 2 * int.from_bytes(data[pos + 2 : pos + 4], "little")
        start = pos + 4
        if start + size > len(data):
            raise TruncatedError(
                f"SII: category {kind} at byte {pos} holds {size} bytes, "
                f"{len(data) - start} are left",
                offset=pos,
            )
        body = data[start : start + size]
        decoder = _DECODERS.get(kind)
        if decoder is None or decoder[0] in fields:
            others.append(SiiCategory(kind, body))
        else:
            fields[decoder[0]] = decoder[1](body, start)
        pos = start + size
    if len(data) < eeprom_bytes:
        findings.append(
            warning("sii.short", f"SII: {len(data)} bytes, the size word says {eeprom_bytes}")
        )
    image = SiiImage(
        config_data=config,
        vendor_id=vendor,
        product_code=product,
        revision=revision,
        serial=serial,
        eeprom_bytes=eeprom_bytes,
        bootstrap_rx_mailbox=(words[0], words[1]),
        bootstrap_tx_mailbox=(words[2], words[3]),
        standard_rx_mailbox=(words[4], words[5]),
        standard_tx_mailbox=(words[6], words[7]),
        mailbox_protocols=words[8],
        version=version,
        other_categories=tuple(others),
        **fields,  # type: ignore[arg-type]
    )
    return DecodedSii(image, tuple(findings), checksum, pos)


def _general(body: bytes, offset: int) -> SiiGeneral:
    if len(body) < _GENERAL.size:
        raise LengthMismatchError(
            f"SII GENERAL: {len(body)} bytes, expected {_GENERAL.size}", offset=offset
        )
    g = _GENERAL.unpack_from(body)
    return SiiGeneral(
        group_index=g[0],
        image_index=g[1],
        order_index=g[2],
        name_index=g[3],
        reserved_byte_4=g[4],
        coe_details=g[5],
        foe_details=g[6],
        eoe_details=g[7],
        soe_channels=g[8],
        ds402_channels=g[9],
        sysman_class=g[10],
        flags=g[11],
        current_on_ebus_ma=g[12],
        physical_ports=g[15],
        physical_memory_address=g[16],
    )


def _fmmus(body: bytes, offset: int) -> tuple[int, ...]:
    # one byte per FMMU; an odd count is padded with one 0x00 to a whole word
    return tuple(body[:-1] if len(body) % 2 == 0 and body and body[-1] == 0 else body)


def _syncms(body: bytes, offset: int) -> tuple[SiiSyncManager, ...]:
    return tuple(
        SiiSyncManager(
            start,
            length,
            control,
            enable,
            _enum(SyncManagerType, kind, f"SYNCM {i}", offset),
            status,
        )
        for i, (start, length, control, status, enable, kind) in enumerate(
            _records(body, _SYNCM, "SYNCM", offset)
        )
    )


def _dcs(body: bytes, offset: int) -> tuple[SiiDc, ...]:
    return tuple(SiiDc(*r) for r in _records(body, _DC, "DC", offset))


_DECODERS: Final[dict[int, tuple[str, Callable[[bytes, int], object]]]] = {
    Category.STRINGS: ("strings", _strings),
    Category.GENERAL: ("general", _general),
    Category.FMMU: ("fmmus", _fmmus),
    Category.SYNCM: ("sync_managers", _syncms),
    Category.TXPDO: ("tx_pdos", lambda b, o: _pdo_list(b, "TXPDO", o)),
    Category.RXPDO: ("rx_pdos", lambda b, o: _pdo_list(b, "RXPDO", o)),
    Category.DC: ("dc", _dcs),
}


# --- from an ESI device ------------------------------------------------------------------------
# an ESI's Sm and Fmmu texts (ETG.2000) as the SII's SyncManager types and FMMU uses (ETG.2010)
ESI_SM_TYPES: Final = {
    "MBoxOut": SyncManagerType.MAILBOX_OUT,
    "MBoxIn": SyncManagerType.MAILBOX_IN,
    "Outputs": SyncManagerType.OUTPUTS,
    "Inputs": SyncManagerType.INPUTS,
    "": SyncManagerType.UNUSED,
}
ESI_FMMU_USES: Final = {
    "Outputs": FmmuUsage.OUTPUTS,
    "Inputs": FmmuUsage.INPUTS,
    "MBoxState": FmmuUsage.SYNCM_STATUS,
    "": FmmuUsage.UNUSED,
}


class _Strings:
    """The string table being built: 1-based indices, each text once, at most 255."""

    def __init__(self) -> None:
        self.items: list[str] = []

    def index(self, text: str, *, required: bool = False) -> int:
        if not text:
            return 0
        if text in self.items:
            return self.items.index(text) + 1
        if len(self.items) == MAX_STRINGS:
            if required:
                raise FieldRangeError("SII: more than 255 strings")
            return 0  # the table is full: this (PDO or entry) name goes without
        if len(text.encode("utf-8")) > 0xFF:
            text = text.encode("utf-8")[:0xFF].decode("utf-8", "ignore")
        self.items.append(text)
        return len(self.items)


@dataclass(frozen=True, slots=True)
class SiiFromEsi:
    """What :func:`sii_from_esi` built: the image, and what it left out to fit ByteSize."""

    image: SiiImage
    omitted: tuple[str, ...]


# What sii_from_esi leaves out, one step after the other, while the image exceeds ByteSize:
# (description, entry names, PDO and DC names, PDO categories; CoE devices only for the last)
_SHRINK_STEPS: Final = (
    ("", True, True, True),
    ("the names of PDO entries", False, True, True),
    ("the names of PDOs and DC op modes", False, False, True),
    ("the TXPDO and RXPDO categories (a CoE master reads the PDOs over CoE)", False, False, False),
)


def sii_from_esi(esi: EsiFile, device: EsiDevice, *, serial: int = 0) -> SiiFromEsi:
    """The SII image ``device`` of ``esi`` describes, fitted to its ``Eeprom/ByteSize``.

    See :func:`image_from_esi` for what goes where. Where the whole image exceeds ByteSize,
    these are left out, one after the other, until it fits (and listed in ``omitted``): the
    names of PDO entries, the names of PDOs and DC op modes, and, for a device with CoE, the
    TXPDO and RXPDO categories (a CoE master reads the PDOs over CoE).

    Raises:
        FieldRangeError: see :func:`image_from_esi`; or the image does not fit ByteSize.
    """
    has_coe = device.mailbox is not None and device.mailbox.coe is not None
    omitted: list[str] = []
    for what, entry_names, names, pdos in _SHRINK_STEPS:
        if what:
            if not pdos and not has_coe:
                break
            omitted.append(what)
        image = image_from_esi(
            esi, device, serial=serial, entry_names=entry_names, names=names, pdos=pdos
        )
        if len(_content(image)) <= image.eeprom_bytes:
            return SiiFromEsi(image, tuple(omitted))
    needed = len(_content(image))
    raise FieldRangeError(
        f"SII: device {device.type_name} needs {needed} bytes of EEPROM, its ByteSize is "
        f"{image.eeprom_bytes}",
        field="eeprom_bytes",
    )


def image_from_esi(
    esi: EsiFile,
    device: EsiDevice,
    *,
    serial: int = 0,
    entry_names: bool = True,
    names: bool = True,
    pdos: bool = True,
) -> SiiImage:
    """The whole SII image ``device`` of ``esi`` describes (ETG.2010 from ETG.2000), unfitted.

    Header: ConfigData zero-padded to words 0-6, the identity, BootStrap, the standard
    mailboxes from the MBoxOut/MBoxIn Sms (offset, DefaultSize), the mailbox protocols and
    ByteSize. Strings: the Type text (order), the group's name and the device's name first,
    then PDO, PDO entry and DC op-mode names while the table has room (255). GENERAL: CoE
    details from the CoE attributes, FoE/EoE 1 when present, the mailbox data link layer flag,
    the ports from ``Physics``. FMMU, SYNCM (DefaultSize 0 where absent), TXPDO, RXPDO
    (flags mandatory 0x01, default 0x02 (an Sm given) and fixed 0x10; SM 0xFF where none is
    assigned), DC (the op modes), then any ``Eeprom/Category`` the ESI gives ready-made.
    A modular device's image has only the ``Device``'s own PDOs: its modules' PDOs depend on
    the slot configuration the master downloads at run time (ETG.5001: 0xF030, and the
    PDO assignment 0x1C12/0x1C13), which no SII can hold.

    Raises:
        FieldRangeError: the device has no ``Eeprom`` element, ConfigData longer than 14
            bytes, or a value that does not fit its SII field.
    """
    eeprom = device.eeprom
    if eeprom is None:
        raise FieldRangeError(
            f"SII: device {device.type_name} (line {device.line}) has no <Eeprom> (ByteSize, "
            "ConfigData)"
        )
    if len(eeprom.config_data) > CONFIG_AREA_BYTES:
        raise FieldRangeError(
            f"SII: ConfigData of {device.type_name} (line {device.line}) is "
            f"{len(eeprom.config_data)} bytes, "
            f"words 0-6 hold {CONFIG_AREA_BYTES}"
        )
    strings = _Strings()
    order = strings.index(device.type_name, required=True)
    group = strings.index(esi.group_name(device.group_type) or device.group_type, required=True)
    name = strings.index(device.name, required=True)

    def mailbox(kind: str) -> tuple[int, int]:
        for sm in device.sync_managers:
            if sm.kind == kind:
                return sm.start_address, sm.default_size_bytes or 0
        return 0, 0

    boot = eeprom.bootstrap or bytes(8)
    b = struct.unpack("<4H", boot)
    mbx = device.mailbox
    protocols = 0
    general = SiiGeneral(
        group_index=group,
        order_index=order,
        name_index=name,
        current_on_ebus_ma=device.ebus_current_ma,
        physical_ports=_ports(device.physics),
    )
    if mbx is not None:
        for present, bit in (
            (mbx.aoe, MailboxProtocol.AOE),
            (mbx.eoe, MailboxProtocol.EOE),
            (mbx.coe is not None, MailboxProtocol.COE),
            (mbx.foe, MailboxProtocol.FOE),
            (mbx.soe, MailboxProtocol.SOE),
            (mbx.voe, MailboxProtocol.VOE),
        ):
            protocols |= bit if present else 0
        coe = 0
        if mbx.coe is not None:
            coe = COE_SDO
            coe |= COE_SDO_INFO if mbx.coe.sdo_info else 0
            coe |= COE_PDO_ASSIGN if mbx.coe.pdo_assign else 0
            coe |= COE_PDO_CONFIG if mbx.coe.pdo_config else 0
            coe |= COE_UPLOAD_AT_STARTUP if mbx.coe.pdo_upload else 0
            coe |= COE_COMPLETE_ACCESS if mbx.coe.complete_access else 0
        general = dataclasses.replace(
            general,
            coe_details=coe,
            foe_details=int(mbx.foe),
            eoe_details=int(mbx.eoe),
            soe_channels=int(mbx.soe),
            flags=GENERAL_FLAG_MBOX_DATA_LINK_LAYER if mbx.data_link_layer else 0,
        )

    def pdo(p: EsiPdo) -> SiiPdo:
        flags = (PDO_MANDATORY if p.mandatory else 0) | (PDO_FIXED_CONTENT if p.fixed else 0)
        flags |= PDO_DEFAULT if p.sync_manager is not None else 0
        return SiiPdo(
            index=p.index,
            sync_manager=PDO_NOT_ASSIGNED if p.sync_manager is None else p.sync_manager,
            entries=tuple(
                SiiPdoEntry(
                    index=e.index,
                    subindex=e.subindex,
                    bit_length=e.bit_length,
                    data_type=DATA_TYPE_CODES.get(e.data_type.upper(), 0),
                    name_index=strings.index(e.name) if entry_names else 0,
                )
                for e in p.entries
            ),
            name_index=strings.index(p.name) if names else 0,
            flags=flags,
        )

    tx = tuple(pdo(p) for p in device.tx_pdos) if pdos else ()
    rx = tuple(pdo(p) for p in device.rx_pdos) if pdos else ()
    dc = tuple(
        SiiDc(
            cycle_time_0_ns=m.cycle_time_sync0_ns,
            # a negative ESI shift time (xs:int) as its two's complement in the 32-bit field
            shift_time_0_ns=m.shift_time_sync0_ns & 0xFFFF_FFFF,
            shift_time_1_ns=m.shift_time_sync1_ns & 0xFFFF_FFFF,
            sync1_cycle_factor=m.cycle_time_sync1_factor,
            assign_activate=m.assign_activate,
            sync0_cycle_factor=m.cycle_time_sync0_factor,
            name_index=strings.index(m.name) if names else 0,
            description_index=strings.index(m.description) if names else 0,
        )
        for m in device.dc_op_modes
    )
    return SiiImage(
        config_data=eeprom.config_data.ljust(CONFIG_AREA_BYTES, b"\x00"),
        vendor_id=esi.vendor.vendor_id,
        product_code=device.product_code,
        revision=device.revision,
        serial=serial,
        eeprom_bytes=eeprom.byte_size,
        bootstrap_rx_mailbox=(b[0], b[1]),
        bootstrap_tx_mailbox=(b[2], b[3]),
        standard_rx_mailbox=mailbox("MBoxOut"),
        standard_tx_mailbox=mailbox("MBoxIn"),
        mailbox_protocols=protocols,
        strings=tuple(strings.items),
        general=general,
        fmmus=tuple(ESI_FMMU_USES[f.kind] for f in device.fmmus),
        sync_managers=tuple(
            SiiSyncManager(
                sm.start_address,
                sm.default_size_bytes or 0,
                sm.control_byte,
                sm.enable,
                ESI_SM_TYPES[sm.kind],
            )
            for sm in device.sync_managers
        ),
        tx_pdos=tx,
        rx_pdos=rx,
        dc=dc,
        other_categories=tuple(SiiCategory(c.category_type, c.data) for c in eeprom.categories),
    )


def _ports(physics: str) -> int:
    value = 0
    for port, letter in enumerate(physics[:4]):
        value |= PORT_TYPES.get(letter.upper(), 0) << (4 * port)
    return value
