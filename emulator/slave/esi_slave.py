"""A slave described by an ESI file (ETG.2000), served by the emulated ESC.

The ESC is the same :class:`~emulator.esc.device.EscDevice` a skin patch has; behind its PDI runs
:class:`EsiApplication`, a :class:`~emulator.slave.state_machine.SlaveApplication` (the ESM,
the mailbox and CoE server, the SyncManager checks) with what the ESI describes:

* the SII image :func:`skinframes.sii.sii_from_esi` builds (what ``skinframes sii ESI.xml``
  writes, serial number 0), so a master reads the ESI's identity, mailbox, SyncManagers, FMMUs
  and PDOs from the EEPROM;
* a modular device's modules (``--esi-modules``, :func:`skinframes.esi.configure_slots`): their
  PDOs and objects join the device's, in their slots;
* the CoE dictionary of :mod:`emulator.slave.esi_objects` when the ESI has CoE (SDO upload and
  download, complete access, SDO information listing the ESI's objects, and 0x1C00/0x1C1n
  where the ESI lacks them);
* the PDO assignment and mapping a master sets in PRE-OP, checked in PRE-OP -> SAFE-OP against
  the SyncManagers' lengths (ETG.1000.6 6.4, AL status codes 0x001D/0x001E);
* inputs that change: every entry the assigned TxPDOs map holds the number of publications so
  far (:meth:`EsiApplication.count`), cut to its bit length (a bit toggles, a UDINT counts),
  packed as the mapping lays the entries out (ETG.1000.6 5.6.7); gaps (index 0) stay 0;
* distributed clocks (the ESC's feature bits 0x0008) only when the ESI has ``Dc`` op modes;
  then, once SYNC0 runs, inputs are sampled at its pulses.

* outputs: when the master completes an output SyncManager's buffer, the application reads it
  through the PDI and, in OP, each entry the assigned RxPDOs map takes its bits (SDO uploads
  of the ``0x7000``-area objects return them; :meth:`EsiApplication.take_outputs`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.esc.dc import DC_FEATURES
from emulator.esc.device import EscDevice
from emulator.esc.pdi import Pdi
from emulator.esc.registers import EscConfig
from emulator.slave.esi_inputs import EsiInputs, pack_entries, read_esi_inputs
from emulator.slave.esi_objects import EsiDictionary, esi_dictionary
from emulator.slave.objects import ObjectDictionary
from emulator.slave.sii import Pdo, PdoEntry, SlaveInfo, SyncManagerSpec
from emulator.slave.state_machine import SlaveApplication
from skinframes.errors import EsiFormatError, SkinframesError
from skinframes.esi import EsiDevice, EsiFile, EsiPdo, configure_slots, read_esi
from skinframes.sii import (
    DATA_TYPE_CODES,
    ESI_FMMU_USES,
    ESI_SM_TYPES,
    SyncManagerType,
    encode_sii,
    sii_from_esi,
)

__all__ = [
    "EsiApplication",
    "EsiSlave",
    "check_esi_slave",
    "check_esi_slaves",
    "counter_images",
    "entry_values",
    "esi_device",
    "load_esi_slave",
    "parse_esi_spec",
    "slave_info",
]

COUNTER_BITS: Final = 63  # a counter's bits that can be 1 (it is a non-negative int64)
ESC_SYNCMANAGERS: Final = 8  # the emulated ESC's default register set (EscConfig)
ESC_FMMUS: Final = 8


@dataclasses.dataclass(frozen=True, slots=True)
class EsiSlave:
    """One device of an ESI file, ready to serve: the file, the device and its SII image."""

    esi: EsiFile
    device: EsiDevice
    sii: bytes
    source: str = ""
    inputs: EsiInputs | None = None  # input values from a file (serve ecat --esi-inputs)

    @property
    def label(self) -> str:
        """``FILE#TYPE`` as a user names it."""
        return f"{self.source}#{self.device.type_name}"

    def summary(self) -> dict[str, str | int]:
        """What ``serve``'s and ``simulate``'s JSON say of it (key ``esi``; ``inputs``, the
        inputs file, only with one; ``modules``, the idents in its slots, only with some)."""
        out: dict[str, str | int] = {
            "file": self.source,
            "type": self.device.type_name,
            "name": self.device.name,
            "vendor_id": self.esi.vendor.vendor_id,
            "product_code": self.device.product_code,
            "revision": self.device.revision,
        }
        if self.inputs is not None:
            out["inputs"] = self.inputs.source
        if self.device.configured_modules:
            out["modules"] = ",".join(f"{m:#x}" for m in self.device.configured_modules)
        return out


def parse_esi_spec(spec: str) -> tuple[str, str | None]:
    """``ESI.xml[#TYPE]`` -> (path, TYPE or None)."""
    path, sep, selector = spec.rpartition("#")
    if not sep:
        return spec, None
    return path, selector or None


def load_esi_slave(spec: str, modules: Sequence[str] | None = None) -> EsiSlave:
    """Read ``ESI.xml[#TYPE]`` and build the device's SII image; a modular device gets the
    ``modules`` (selectors, :func:`skinframes.esi.configure_slots`) in its slots, its SII
    stays the device's own (ETG.5001: the modules' PDOs are read over CoE); no modules (``[]``,
    ``--esi-modules ''``) suit a device without slots too.

    Raises:
        EsiFormatError: the file is no usable ESI, TYPE names no device of it, or the modules
            do not fit its slots.
        SkinframesError: the image cannot be built (no Eeprom element, too large).
        OSError: the file cannot be read.
    """
    path, selector = parse_esi_spec(spec)
    esi = read_esi(Path(path))
    device = esi.device(selector)
    image = sii_from_esi(esi, device).image
    if modules is not None and (modules or device.slots is not None):
        device = configure_slots(esi, device, modules)
    return EsiSlave(esi, device, encode_sii(image), source=path)


def _pdo(p: EsiPdo) -> Pdo:
    entries = tuple(
        PdoEntry(e.index, e.subindex, e.bit_length, DATA_TYPE_CODES.get(e.data_type.upper(), 0))
        for e in p.entries
    )
    assert p.sync_manager is not None
    return Pdo(p.index, p.sync_manager, entries, name=p.name)


def slave_info(esi: EsiFile, device: EsiDevice, *, serial: int = 0) -> SlaveInfo:
    """The small description the ESC's firmware works from (SyncManagers, FMMUs, the PDOs the
    ESI assigns by default).

    Raises:
        TopologyError: a PDO assigned to a SyncManager the device does not have, or one of the
            other direction; more SyncManagers or FMMUs than an ESC has (16).
    """
    sms = tuple(
        SyncManagerSpec(
            s.start_address,
            s.default_size_bytes or 0,
            s.control_byte,
            s.enable,
            ESI_SM_TYPES[s.kind],
        )
        for s in device.sync_managers
    )
    where = f"ESI device {device.type_name} (line {device.line})"
    for kind, pdos, expected in (
        ("RxPdo", device.rx_pdos, SyncManagerType.OUTPUTS),
        ("TxPdo", device.tx_pdos, SyncManagerType.INPUTS),
    ):
        for p in pdos:
            if p.sync_manager is None:
                continue
            if not 0 <= p.sync_manager < len(sms):
                raise TopologyError(
                    f"{where}: {kind} {p.index:#06x} is assigned to Sm {p.sync_manager}, the "
                    f"device has {len(sms)} SyncManagers"
                )
            if sms[p.sync_manager].type != expected:
                raise TopologyError(
                    f"{where}: {kind} {p.index:#06x} is assigned to Sm {p.sync_manager}, a "
                    f"SyncManager of type {sms[p.sync_manager].type.name}"
                )
    if len(sms) > 16 or len(device.fmmus) > 16:
        raise TopologyError(f"{where}: more than 16 SyncManagers or FMMUs")
    mbx = device.mailbox
    return SlaveInfo(
        vendor_id=esi.vendor.vendor_id,
        product_code=device.product_code,
        revision=device.revision,
        serial=serial,
        name=device.name,
        sync_managers=sms,
        fmmus=tuple(ESI_FMMU_USES[f.kind] for f in device.fmmus),
        tx_pdos=tuple(_pdo(p) for p in device.tx_pdos if p.sync_manager is not None),
        rx_pdos=tuple(_pdo(p) for p in device.rx_pdos if p.sync_manager is not None),
        mailbox_protocols=0 if mbx is None else 0x0004 * (mbx.coe is not None),
    )


class EsiApplication(SlaveApplication):
    """The firmware of an ESI-described slave (see the module docstring)."""

    objects: EsiDictionary | None

    def __init__(
        self, esi: EsiFile, device: EsiDevice, info: SlaveInfo, inputs: EsiInputs | None = None
    ) -> None:
        self.esi, self.esi_device = esi, device
        self.counter = 0  # publications so far: what every input entry holds
        self.input_file = inputs  # values from a file for the entries it names
        super().__init__(info)
        self._input_sms = [
            (i, sm.start)
            for i, sm in enumerate(info.sync_managers)
            if sm.type == SyncManagerType.INPUTS
        ]

    def dictionary(self) -> ObjectDictionary | None:
        """The ESI's dictionary when it has CoE, else None."""
        mbx = self.esi_device.mailbox
        if mbx is None or mbx.coe is None:
            return None
        return esi_dictionary(
            self.esi, self.esi_device, serial=self.info.serial, input_value=self.input_value
        )

    # --- inputs ----------------------------------------------------------------------------
    def input_value(self, index: int, subindex: int, bits: int) -> bytes:
        """An input entry's bytes now: the inputs file's value, else the counter, cut to
        ``bits``."""
        return (self._value(index, subindex) % (1 << bits)).to_bytes((bits + 7) // 8, "little")

    def _value(self, index: int, subindex: int, publication: int | None = None) -> int:
        """An input entry's value at ``publication`` (default: now, :attr:`counter`): the
        inputs file's, else the counter's."""
        at = self.counter if publication is None else publication
        file = self.input_file
        found = None if file is None else file.value(index, subindex, at)
        return at if found is None else found

    def count(self, device: Pdi) -> None:
        """The next publication: every input entry counts one up (written unless SYNC0
        samples them)."""
        self.counter += 1
        if not device.dc_sampling:
            self._write_inputs(device)

    def sync0(self, device: Pdi, pulse_ns: int) -> None:
        """A SYNC0 pulse: the inputs are sampled (written into their buffers)."""
        self._write_inputs(device)

    def layout(self, sync_manager: int) -> list[tuple[int, int, int]]:
        """(index, subindex, bits) of the entries SyncManager ``sync_manager`` carries, in
        order: the assigned PDOs' mappings (CoE), else the SII's default PDOs."""
        if self.objects is not None and sync_manager in self.objects.assignments:
            return [e for pdo in self.objects.assigned(sync_manager) for e in self._mapped(pdo)]
        return [
            (e.index, e.subindex, e.bit_length)
            for p in self.info.tx_pdos + self.info.rx_pdos
            if p.sync_manager == sync_manager
            for e in p.entries
        ]

    def _mapped(self, pdo: int) -> list[tuple[int, int, int]]:
        assert self.objects is not None
        if pdo in self.objects.mappings:
            return self.objects.mapped(pdo)
        found = next((p for p in self.info.tx_pdos + self.info.rx_pdos if p.index == pdo), None)
        return [] if found is None else [(e.index, e.subindex, e.bit_length) for e in found.entries]

    def image(self, sync_manager: int) -> bytes:
        """The bytes of input SyncManager ``sync_manager`` now (:meth:`images`)."""
        return bytes(self.images(sync_manager, np.array([self.counter], dtype=np.int64))[0])

    def images(
        self, sync_manager: int, publications: npt.NDArray[np.int64]
    ) -> npt.NDArray[np.uint8]:
        """(len(publications), bytes): the bytes of input SyncManager ``sync_manager`` at each
        of ``publications`` (non-negative): :func:`counter_images`, or with an inputs file
        :func:`pack_entries` of its values and the counter's. What ``serve`` publishes and the
        timing engine's master reads (:class:`emulator.net.ecat_line.EcatLine`)."""
        layout = self.layout(sync_manager)
        if self.input_file is None:
            return counter_images(layout, publications)
        rows = [
            pack_entries(layout, [self._value(i, s, c) for i, s, _ in layout])
            for c in publications.tolist()
        ]
        width = (sum(bits for _, _, bits in layout) + 7) // 8
        return np.frombuffer(b"".join(rows), np.uint8).reshape(len(rows), width)

    # --- outputs ---------------------------------------------------------------------------
    def take_outputs(self, index: int, data: bytes) -> None:
        """Outputs of SyncManager ``index`` (in OP, :meth:`SlaveApplication.outputs_event`):
        each entry its assigned RxPDOs map (``0x7000``-area objects, usually) takes its bits
        of ``data`` (:func:`entry_values`), readable over SDO."""
        super().take_outputs(index, data)
        if self.objects is None:
            return
        for obj, sub, value in entry_values(self.layout(index), data):
            entry = self.objects.entry(obj, sub)
            if not isinstance(entry, int) and entry.reader is None:
                entry.value = value

    def _write_inputs(self, device: Pdi) -> None:
        for index, start in self._input_sms:
            data = self.image(index)
            if data:
                device.pdi_write(start, data)

    def _first_inputs(self, device: Pdi) -> None:
        self._write_inputs(device)

    def sm_bytes(self, index: int) -> int:
        """Bytes of the entries assigned to SyncManager ``index`` now."""
        return (sum(bits for _, _, bits in self.layout(index)) + 7) // 8


def counter_images(
    layout: Sequence[tuple[int, int, int]], counters: npt.NDArray[np.int64]
) -> npt.NDArray[np.uint8]:
    """(len(counters), bytes): the SyncManager buffer whose entries ``layout`` lists ((index,
    subindex, bits), in mapping order) when every entry holds a counter, cut to its bits; one
    row per counter (non-negative, below 2**63). ETG.1000.6 5.6.7: the entries packed bit by
    bit, the first at bit 0 of the first byte, little-endian; a gap (index 0) stays 0."""
    total = sum(bits for _, _, bits in layout)
    plane = np.zeros((len(counters), -(-total // 8) * 8), np.uint8)
    at = 0
    for index, _, bits in layout:
        if index:
            n = min(bits, COUNTER_BITS)
            plane[:, at : at + n] = (counters[:, None] >> np.arange(n, dtype=np.int64)) & 1
        at += bits
    return np.packbits(plane, axis=1, bitorder="little")


def entry_values(
    layout: Sequence[tuple[int, int, int]], data: bytes
) -> list[tuple[int, int, bytes]]:
    """(index, subindex, value) of the entries ``layout`` maps ((index, subindex, bits), in
    mapping order) in the SyncManager buffer ``data``: ETG.1000.6 5.6.7, the entries packed bit
    by bit from bit 0 (what :func:`counter_images` packs), each value its bits in whole bytes,
    little-endian; gaps (index 0) are skipped."""
    whole = int.from_bytes(data, "little")
    out, at = [], 0
    for index, subindex, bits in layout:
        if index:
            value = (whole >> at) & ((1 << bits) - 1)
            out.append((index, subindex, value.to_bytes((bits + 7) // 8, "little")))
        at += bits
    return out


def esi_device(slave: EsiSlave) -> EscDevice:
    """An ESC with ``slave``'s SII image and its application, powered on (INIT).

    Raises:
        TopologyError: what :func:`slave_info` refuses.
    """
    info = slave_info(slave.esi, slave.device)
    config = EscConfig(
        fmmus=max(ESC_FMMUS, len(slave.device.fmmus)),
        syncmanagers=max(ESC_SYNCMANAGERS, len(slave.device.sync_managers)),
        features=DC_FEATURES if slave.device.dc_op_modes else 0,
    )
    app = EsiApplication(slave.esi, slave.device, info, slave.inputs)
    return EscDevice(info, config=config, sii=slave.sii, app=app)


def check_esi_slaves(
    specs: Sequence[str], inputs: Sequence[str] = (), modules: Sequence[str] = ()
) -> list[EsiSlave]:
    """:func:`check_esi_slave` of each of ``specs``, the n-th with the inputs file
    ``inputs[n]`` (:func:`emulator.slave.esi_inputs.read_esi_inputs`) and the modules of the
    comma-separated list ``modules[n]`` ("" for none), as ``--esi``, ``--esi-inputs`` and
    ``--esi-modules`` name them; every failure one :class:`SkinframesError` naming the file."""
    if len(modules) > len(specs):
        raise SkinframesError(
            f"--esi-modules: {len(modules)} lists for {len(specs)} --esi slaves (the n-th "
            "list is the n-th --esi slave's)"
        )
    lists = [[m.strip() for m in x.split(",")] if x.strip() else [] for x in modules]
    slaves = [
        check_esi_slave(spec, lists[k] if k < len(lists) else None) for k, spec in enumerate(specs)
    ]
    if len(inputs) > len(slaves):
        raise SkinframesError(
            f"--esi-inputs: {len(inputs)} files for {len(slaves)} --esi slaves (the n-th "
            "file is the n-th --esi slave's)"
        )
    for k, path in enumerate(inputs):
        if not path:
            raise SkinframesError("--esi-inputs: an empty file name")
        try:
            values = read_esi_inputs(path, slaves[k].device)
        except OSError as exc:
            raise SkinframesError(f"--esi-inputs {path}: {exc.strerror or exc}") from exc
        slaves[k] = dataclasses.replace(slaves[k], inputs=values)
    return slaves


def check_esi_slave(spec: str, modules: Sequence[str] | None = None) -> EsiSlave:
    """:func:`load_esi_slave` with every failure as one :class:`SkinframesError` or
    :class:`TopologyError` naming the file (for the command line)."""
    try:
        slave = load_esi_slave(spec, modules)
        esi_device(slave)  # what the emulator cannot serve fails here, before serving
    except OSError as exc:
        raise EsiFormatError(f"--esi {spec}: {exc.strerror or exc}") from exc
    except (SkinframesError, TopologyError) as exc:
        raise type(exc)(f"--esi {spec}: {exc}") from exc
    return slave
