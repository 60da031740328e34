"""The Slave Information Interface (SII) of an emulated EtherCAT slave: what goes into it.

The image's bytes are :mod:`skinframes.sii`'s (ETG.1000.6 clause 5.4 / ETG.2010, the one SII
encoder and decoder); this module decides what an emulated slave puts there. A
:class:`SlaveInfo` is the small description an image is built from (:func:`build_sii`);
:meth:`SlaveInfo.skin_patch` describes one tactile patch whose TxPDO carries its taxel bytes.

The categories written: STRINGS (10), GENERAL (30), FMMU (40), SYNCM (41), TXPDO (50) and
RXPDO (51) when the slave has outputs (ETG.2010 Tables 4-13). GENERAL byte 5 carries the CoE
details (bit 0 SDO, 1 SDO information, 2 PDO assign, 3 PDO configuration, 4 upload at start-up,
5 SDO complete access; ETG.2010 Table 6), which SOEM reads to choose complete access. The
standard mailbox words 0x18-0x1B hold SM0 (receive, master -> slave) and SM1 (send); all 0 for a
slave without a mailbox. The image is padded with 0xFF to the smallest power-of-two EEPROM
(>= 2 Kibit) that holds it.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import Final

from emulator.errors import TopologyError
from skinframes import taxel
from skinframes.sii import (
    CHECKSUM_BYPASS,
    CONFIG_AREA_BYTES,
    FIRST_CATEGORY_WORD,
    Category,
    FmmuUsage,
    SiiGeneral,
    SiiImage,
    SiiPdo,
    SiiPdoEntry,
    SiiSyncManager,
    SyncManagerType,
    crc8,
    encode_sii,
    fit_eeprom,
)
from skinframes.sii import standard_eeprom_kibit as eeprom_kibit

__all__ = [
    "CHECKSUM_BYPASS",
    "CONFIG_AREA_WORDS",
    "FIRST_CATEGORY_WORD",
    "PRODUCT_CODE_BASE",
    "VENDOR_ID",
    "Category",
    "DataType",
    "FmmuUsage",
    "Pdo",
    "PdoEntry",
    "SlaveInfo",
    "SyncManagerSpec",
    "SyncManagerType",
    "build_sii",
    "crc8",
    "eeprom_kibit",
    "sii_image",
]

CONFIG_AREA_WORDS: Final = CONFIG_AREA_BYTES // 2  # words 0-6 are covered by the checksum
MIN_EEPROM_KIBIT: Final = 2  # datasheet I, 11: words 0-63 plus General need at least 2 Kibit
PDI_SPI_SLAVE: Final = 0x05  # 0x0140 PDI control: SPI slave (datasheet II, 2.6.1)
PHYSICAL_PORT_MII: Final = 0x1  # GENERAL byte 16: 4 bits per port, 1 = MII

# Identity of the emulated skin patch. "SKIN" in ASCII: a vendor ID chosen for the emulator,
# not one assigned by the ETG; the product code carries the patch's input size.
VENDOR_ID: Final = 0x534B494E
PRODUCT_CODE_BASE: Final = 0x00010000
REVISION: Final = 0x00010000  # major 1, minor 0
PROCESS_RAM_START: Final = 0x1000  # datasheet I, 1.1: process memory starts at 0x1000

# Mailbox protocols, SII word 0x1C (ETG.2010 Table 2) and CoE details, GENERAL byte 5 (Table 6)
MBX_PROTOCOL_COE: Final = 0x0004
COE_SDO: Final = 0x01
COE_SDO_INFO: Final = 0x02
COE_PDO_ASSIGN: Final = 0x04
COE_PDO_CONFIG: Final = 0x08
COE_UPLOAD_AT_STARTUP: Final = 0x10
COE_COMPLETE_ACCESS: Final = 0x20
# The skin patch's mailbox: two 128-byte buffers at the start of process RAM, SOEM's and the
# Beckhoff terminals' default (SOEM ethercatconfig.c falls back to 0x1000/0x1080, 128 bytes).
MAILBOX_BYTES: Final = 128
MAILBOX_OUT_START: Final = 0x1000
MAILBOX_IN_START: Final = 0x1080


class DataType(IntEnum):
    """CoE basic data types used in PDO entries (ETG.1000.6 Table 64; SOEM's ECT_* values)."""

    BOOLEAN = 0x0001
    INTEGER8 = 0x0002
    INTEGER16 = 0x0003
    INTEGER32 = 0x0004
    UNSIGNED8 = 0x0005
    UNSIGNED16 = 0x0006
    UNSIGNED32 = 0x0007
    VISIBLE_STRING = 0x0009
    OCTET_STRING = 0x000A
    PDO_MAPPING = 0x0021  # record type of 0x1600/0x1A00 (ETG.1000.6 Table 64)
    IDENTITY = 0x0023  # record type of 0x1018


# SyncManager control bytes (datasheet II, 2.14.3): bits 1:0 mode (00 buffered), bits 3:2
# direction (00 ECAT reads, 01 ECAT writes), bit 5 interrupt in AL event, bit 6 watchdog.
SM_CONTROL_INPUTS: Final = 0x20
SM_CONTROL_OUTPUTS: Final = 0x64
# mailbox mode (bits 1:0 = 10) with the PDI interrupt (bit 5): SOEM's EC_DEFAULTMBXSM0/1
SM_CONTROL_MAILBOX_OUT: Final = 0x26
SM_CONTROL_MAILBOX_IN: Final = 0x22


@dataclass(frozen=True, slots=True)
class PdoEntry:
    """One PDO entry (ETG.2010 Table 12): object index/subindex, data type and bit length."""

    index: int
    subindex: int
    bit_length: int
    data_type: int = DataType.UNSIGNED8
    name_index: int = 0
    flags: int = 0


@dataclass(frozen=True, slots=True)
class Pdo:
    """One PDO (ETG.2010 Table 11) and the SyncManager it is assigned to."""

    index: int
    sync_manager: int
    entries: tuple[PdoEntry, ...]
    name: str = ""
    synchronization: int = 0
    flags: int = 0

    @property
    def bit_length(self) -> int:
        """Sum of the entries' bit lengths: what the PDO occupies in the SyncManager."""
        return sum(e.bit_length for e in self.entries)


@dataclass(frozen=True, slots=True)
class SyncManagerSpec:
    """One SYNCM entry (ETG.2010 Table 9): the configuration a master programs into 0x0800+."""

    start: int
    length: int
    control: int
    enable: int
    type: SyncManagerType

    @property
    def ecat_writes(self) -> bool:
        """Direction bits 3:2 = 01: the master writes (outputs, mailbox out)."""
        return (self.control >> 2) & 0x3 == 1


@dataclass(frozen=True, slots=True)
class SlaveInfo:
    """What an emulated slave tells a master through its SII (the small description).

    ``sync_managers`` and ``fmmus`` are listed in the SII in order; ``tx_pdos`` (inputs) and
    ``rx_pdos`` (outputs) name the SyncManager they are mapped to. ``alias`` goes to word 4.
    """

    vendor_id: int
    product_code: int
    revision: int
    serial: int
    name: str
    sync_managers: tuple[SyncManagerSpec, ...]
    fmmus: tuple[FmmuUsage, ...]
    tx_pdos: tuple[Pdo, ...] = ()
    rx_pdos: tuple[Pdo, ...] = ()
    alias: int = 0
    group: str = ""
    order: str = ""
    pdi_control: int = PDI_SPI_SLAVE
    esc_configuration: int = 0x00  # 0x0141: no device emulation, no enhanced link detection
    mailbox_protocols: int = 0  # SII word 0x1C
    coe_details: int = 0  # GENERAL byte 5

    def __post_init__(self) -> None:
        for label, value, bits in (
            ("vendor_id", self.vendor_id, 32),
            ("product_code", self.product_code, 32),
            ("revision", self.revision, 32),
            ("serial", self.serial, 32),
            ("alias", self.alias, 16),
        ):
            if not 0 <= value < 1 << bits:
                raise TopologyError(f"SII: {label} {value:#x} does not fit {bits} bits")
        for pdo in self.tx_pdos + self.rx_pdos:
            if not 0 <= pdo.sync_manager < len(self.sync_managers):
                raise TopologyError(f"SII: PDO {pdo.index:#06x} names SM{pdo.sync_manager}")
            if len(pdo.entries) > 0xFF:
                raise TopologyError(f"SII: PDO {pdo.index:#06x} has more than 255 entries")

    @property
    def input_bytes(self) -> int:
        """Bytes of inputs (TxPDOs), rounded up to whole bytes."""
        return (sum(p.bit_length for p in self.tx_pdos) + 7) // 8

    @property
    def output_bytes(self) -> int:
        """Bytes of outputs (RxPDOs), rounded up to whole bytes."""
        return (sum(p.bit_length for p in self.rx_pdos) + 7) // 8

    def sm_bytes(self, index: int) -> int:
        """Bytes the PDOs assigned to SyncManager ``index`` occupy (what SOEM programs)."""
        bits = sum(p.bit_length for p in self.tx_pdos + self.rx_pdos if p.sync_manager == index)
        return (bits + 7) // 8

    @property
    def has_mailbox(self) -> bool:
        """True when the SII lists a mailbox SyncManager in each direction."""
        return (
            self.sm_of_type(SyncManagerType.MAILBOX_OUT) is not None
            and self.sm_of_type(SyncManagerType.MAILBOX_IN) is not None
        )

    def sm_of_type(self, kind: SyncManagerType) -> int | None:
        """Index of the first SyncManager of ``kind``, or None."""
        for i, sm in enumerate(self.sync_managers):
            if sm.type == kind:
                return i
        return None

    @classmethod
    def skin_patch(
        cls,
        input_bytes: int = taxel.PATCH_BYTES,
        *,
        serial: int = 0,
        alias: int = 0,
        output_bytes: int = 0,
        mailbox: bool = False,
    ) -> SlaveInfo:
        """A tactile patch: its taxels as TxPDOs, with or without a CoE mailbox.

        Without a mailbox (the default): the taxels are a TxPDO on SM0 at 0x1000. Each taxel is
        one UNSIGNED8 entry, object 0x6000 + triangle, subindex 1-12 (16 triangles of 12 taxels
        make the 192 bytes of a patch); PDO 0x1A00 + k carries 16 triangles. A payload beyond one
        patch uses one 96-bit OCTET_STRING entry per triangle instead, so the SII stays small.
        ``output_bytes`` adds an RxPDO 0x1600 (UNSIGNED8 entries of object 0x7000) on SM1,
        placed after the three buffers of SM0 (datasheet I, 8.1).

        With ``mailbox=True``: the standard layout of a CoE slave (ETG.2010 Table 9, SOEM's
        defaults): SM0/SM1 the 128-byte receive/send mailboxes at 0x1000/0x1080, SM2 the outputs
        (length 0 and disabled without outputs), SM3 the inputs; one TxPDO 0x1A00 + t per
        triangle t mapping its taxels 0x6000 + t:1..12 (see :mod:`emulator.slave.objects` for why
        per triangle), assigned to SM3 through 0x1C13; mailbox protocol CoE with SDO, SDO
        information, PDO assignment and complete access.
        """
        if not 1 <= input_bytes <= 1486:
            raise TopologyError(f"skin patch: {input_bytes} input bytes (1..1486)")
        if not 0 <= output_bytes <= 1486:
            raise TopologyError(f"skin patch: {output_bytes} output bytes (0..1486)")
        if mailbox:
            return cls._skin_patch_coe(input_bytes, serial, alias, output_bytes)
        per = taxel.TAXELS_PER_TRIANGLE
        tx: list[Pdo] = []
        if input_bytes <= taxel.PATCH_BYTES:
            entries = tuple(
                PdoEntry(0x6000 + i // per, i % per + 1, 8, DataType.UNSIGNED8)
                for i in range(input_bytes)
            )
            tx.append(Pdo(0x1A00, 0, entries, name="Taxels"))
        else:
            triangles = [
                PdoEntry(0x6000 + t, 1, 8 * min(per, input_bytes - t * per), DataType.OCTET_STRING)
                for t in range(-(-input_bytes // per))
            ]
            step = taxel.TRIANGLES_PER_PATCH
            for k in range(0, len(triangles), step):
                tx.append(Pdo(0x1A00 + k // step, 0, tuple(triangles[k : k + step]), "Taxels"))
        sms = [
            SyncManagerSpec(
                PROCESS_RAM_START, input_bytes, SM_CONTROL_INPUTS, 1, SyncManagerType.INPUTS
            )
        ]
        fmmus = [FmmuUsage.INPUTS]
        rx: tuple[Pdo, ...] = ()
        if output_bytes:
            start = PROCESS_RAM_START + 3 * (-(-input_bytes // 8) * 8)  # 3 buffers, 8-aligned
            sms.append(
                SyncManagerSpec(start, output_bytes, SM_CONTROL_OUTPUTS, 1, SyncManagerType.OUTPUTS)
            )
            fmmus.insert(0, FmmuUsage.OUTPUTS)  # SOEM maps outputs with the first FMMU
            rx = (_outputs_pdo(output_bytes, 1),)
        return cls._patch(input_bytes, serial, alias, tuple(sms), fmmus, tuple(tx), rx)

    @classmethod
    def _patch(
        cls,
        input_bytes: int,
        serial: int,
        alias: int,
        sms: tuple[SyncManagerSpec, ...],
        fmmus: list[FmmuUsage],
        tx: tuple[Pdo, ...],
        rx: tuple[Pdo, ...],
        *,
        coe: bool = False,
    ) -> SlaveInfo:
        """The identity every skin patch shares (module constants), with its layout."""
        return cls(
            vendor_id=VENDOR_ID,
            product_code=PRODUCT_CODE_BASE + input_bytes,
            revision=REVISION,
            serial=serial,
            name=f"SkinPatch{input_bytes}",
            sync_managers=sms,
            fmmus=tuple(fmmus),
            tx_pdos=tx,
            rx_pdos=rx,
            alias=alias,
            group="RobotSkin",
            order=f"SKIN-{input_bytes}",
            mailbox_protocols=MBX_PROTOCOL_COE if coe else 0,
            coe_details=COE_SDO | COE_SDO_INFO | COE_PDO_ASSIGN | COE_COMPLETE_ACCESS if coe else 0,
        )

    @classmethod
    def _skin_patch_coe(
        cls, input_bytes: int, serial: int, alias: int, output_bytes: int
    ) -> SlaveInfo:
        per = taxel.TAXELS_PER_TRIANGLE
        tx = tuple(
            Pdo(
                0x1A00 + t,
                3,
                tuple(
                    PdoEntry(0x6000 + t, k + 1, 8, DataType.UNSIGNED8)
                    for k in range(min(per, input_bytes - t * per))
                ),
                name=f"Triangle {t}",
            )
            for t in range(-(-input_bytes // per))
        )
        out_start = PROCESS_RAM_START + 2 * MAILBOX_BYTES
        in_start = out_start + 3 * (-(-output_bytes // 8) * 8)  # after SM2's 3 buffers
        sms = (
            SyncManagerSpec(
                MAILBOX_OUT_START,
                MAILBOX_BYTES,
                SM_CONTROL_MAILBOX_OUT,
                1,
                SyncManagerType.MAILBOX_OUT,
            ),
            SyncManagerSpec(
                MAILBOX_IN_START,
                MAILBOX_BYTES,
                SM_CONTROL_MAILBOX_IN,
                1,
                SyncManagerType.MAILBOX_IN,
            ),
            SyncManagerSpec(
                out_start,
                output_bytes,
                SM_CONTROL_OUTPUTS,
                1 if output_bytes else 0,
                SyncManagerType.OUTPUTS,
            ),
            SyncManagerSpec(in_start, input_bytes, SM_CONTROL_INPUTS, 1, SyncManagerType.INPUTS),
        )
        rx: tuple[Pdo, ...] = ()
        fmmus = [FmmuUsage.INPUTS]
        if output_bytes:
            rx = (_outputs_pdo(output_bytes, 2),)
            fmmus.insert(0, FmmuUsage.OUTPUTS)
        return cls._patch(input_bytes, serial, alias, sms, fmmus, tx, rx, coe=True)


def _outputs_pdo(output_bytes: int, sync_manager: int) -> Pdo:
    """RxPDO 0x1600: one UNSIGNED8 entry of object 0x7000 per output byte."""
    out = tuple(PdoEntry(0x7000, i + 1, 8) for i in range(output_bytes))
    return Pdo(0x1600, sync_manager, out, name="Outputs")


# --- the image ---------------------------------------------------------------------------------
def sii_image(info: SlaveInfo) -> SiiImage:
    """``info`` as an SII image model (:class:`skinframes.sii.SiiImage`), fitted to the
    smallest standard EEPROM (>= 2 Kibit) that holds it.

    Strings: the name first (SOEM reads the device name from index 1), then group, order and
    the PDO names. GENERAL carries the CoE details and two MII ports.
    """
    strings: list[str] = []

    def string_index(s: str) -> int:
        if not s:
            return 0
        if s not in strings:
            strings.append(s)
        return strings.index(s) + 1  # string indices are 1-based, 0 means "none"

    name_idx = string_index(info.name)  # string 1: SOEM reads the device name from index 1
    group_idx = string_index(info.group)
    order_idx = string_index(info.order)
    config = bytearray(CONFIG_AREA_BYTES)
    config[0:2] = (info.pdi_control | info.esc_configuration << 8).to_bytes(2, "little")
    config[8:10] = info.alias.to_bytes(2, "little")  # word 4: configured station alias
    rx_mbx = info.sm_of_type(SyncManagerType.MAILBOX_OUT)
    tx_mbx = info.sm_of_type(SyncManagerType.MAILBOX_IN)
    mailboxes: dict[str, object] = {}
    if rx_mbx is not None and tx_mbx is not None:
        rx_sm, tx_sm = info.sync_managers[rx_mbx], info.sync_managers[tx_mbx]
        mailboxes = {
            "standard_rx_mailbox": (rx_sm.start, rx_sm.length),
            "standard_tx_mailbox": (tx_sm.start, tx_sm.length),
            "mailbox_protocols": info.mailbox_protocols,
        }

    def pdos(items: tuple[Pdo, ...]) -> tuple[SiiPdo, ...]:
        return tuple(
            SiiPdo(
                index=p.index,
                sync_manager=p.sync_manager,
                entries=tuple(
                    SiiPdoEntry(
                        e.index, e.subindex, e.bit_length, e.data_type & 0xFF, e.name_index, e.flags
                    )
                    for e in p.entries
                ),
                synchronization=p.synchronization,
                name_index=string_index(p.name),
                flags=p.flags,
            )
            for p in items
        )

    tx, rx = pdos(info.tx_pdos), pdos(info.rx_pdos)  # PDO names join the string table
    for s in strings:
        if len(s.encode("utf-8")) > 0xFF:
            raise TopologyError(f"SII: string {s!r} longer than 255 bytes")
    image = SiiImage(
        config_data=bytes(config),
        vendor_id=info.vendor_id,
        product_code=info.product_code,
        revision=info.revision,
        serial=info.serial,
        eeprom_bytes=MIN_EEPROM_KIBIT * 128,
        strings=tuple(strings),
        general=SiiGeneral(
            group_index=group_idx,
            order_index=order_idx,
            name_index=name_idx,
            coe_details=info.coe_details,
            physical_ports=PHYSICAL_PORT_MII | PHYSICAL_PORT_MII << 4,
        ),
        fmmus=tuple(int(u) for u in info.fmmus),
        sync_managers=tuple(
            SiiSyncManager(s.start, s.length, s.control, s.enable, s.type)
            for s in info.sync_managers
        ),
        tx_pdos=tx,
        rx_pdos=rx,
        **mailboxes,  # type: ignore[arg-type]
    )
    return fit_eeprom(image)


def build_sii(info: SlaveInfo) -> bytes:
    """The EEPROM image of ``info`` (ETG.2010), padded with 0xFF to the EEPROM's size.

    The size in word 0x3E is the smallest power-of-two EEPROM (>= 2 Kibit) holding the image;
    the bytes come from the one SII encoder, :func:`skinframes.sii.encode_sii`.
    """
    return encode_sii(sii_image(info))
