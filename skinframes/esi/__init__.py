"""Read EtherCAT Slave Information (ESI) files: the vendor's XML description of its devices.

ETG.2000 (EtherCAT Slave Information Specification) and its schema EtherCATInfo.xsd: a vendor,
its groups and its devices (identity, FMMUs, SyncManagers, PDOs, mailbox protocols, DC op
modes, EEPROM, CoE object dictionary) and, for modular devices (ETG.5001), the modules their
slots may hold. Anything the reader cannot use raises :class:`~skinframes.errors.EsiFormatError`
naming the element and its line.

Where things are (every name listed is importable from ``skinframes.esi``):

- ``model``: what an ESI says: the constants (:data:`SM_KINDS`, :data:`FMMU_KINDS`, ...), the
  frozen dataclasses (:class:`EsiFile`, :class:`EsiDevice`, :class:`EsiPdo`, :class:`EsiSlots`,
  :class:`EsiModule`, ...), :func:`missing_communication_objects` (the communication objects a
  CoE slave serves that the ESI leaves out) and :func:`parse_number` (numbers as ESI writes
  them, which device selectors take too).
- ``parse``: the XML reader, :func:`read_esi` and :func:`parse_esi` (expat, line numbers kept).
- ``slots``: modular devices: :func:`configure_slots` puts modules in a device's slots.
"""

from skinframes.esi.model import ENGLISH_LCID as ENGLISH_LCID
from skinframes.esi.model import (
    FMMU_KINDS,
    SM_KINDS,
    EsiAlternativeSmMapping,
    EsiCoe,
    EsiDataType,
    EsiDataTypeSubItem,
    EsiDcOpMode,
    EsiDevice,
    EsiDictionary,
    EsiEeprom,
    EsiEepromCategory,
    EsiFile,
    EsiFmmu,
    EsiMailbox,
    EsiModule,
    EsiObject,
    EsiObjectSubItem,
    EsiPdo,
    EsiPdoEntry,
    EsiSlot,
    EsiSlots,
    EsiSyncManager,
    EsiVendor,
    missing_communication_objects,
    parse_number,
)
from skinframes.esi.model import PDO_ASSIGNMENT_BASE as PDO_ASSIGNMENT_BASE
from skinframes.esi.model import SM_COMMUNICATION_TYPES as SM_COMMUNICATION_TYPES
from skinframes.esi.parse import parse_esi, read_esi
from skinframes.esi.slots import configure_slots

__all__ = [
    "FMMU_KINDS",
    "SM_KINDS",
    "EsiAlternativeSmMapping",
    "EsiCoe",
    "EsiDataType",
    "EsiDataTypeSubItem",
    "EsiDcOpMode",
    "EsiDevice",
    "EsiDictionary",
    "EsiEeprom",
    "EsiEepromCategory",
    "EsiFile",
    "EsiFmmu",
    "EsiMailbox",
    "EsiModule",
    "EsiObject",
    "EsiObjectSubItem",
    "EsiPdo",
    "EsiPdoEntry",
    "EsiSlot",
    "EsiSlots",
    "EsiSyncManager",
    "EsiVendor",
    "configure_slots",
    "missing_communication_objects",
    "parse_esi",
    "parse_number",
    "read_esi",
]
