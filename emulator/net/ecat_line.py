"""The slaves of an emulated EtherCAT line and where their inputs lie in its input image.

A line is ``patches`` skin patches of ``patch_bytes`` of taxels each, then the slaves ESI files
describe (:mod:`emulator.slave.esi_slave`), in that order: what ``simulate ecat --nodes N --esi
ESI.xml`` runs. Each slave's inputs (the bytes of its input SyncManager, ETG.1000.6 5.6.7) lie
one after another in the line's input image, in line order; the master reads them with LRDs at
those logical addresses (:func:`emulator.net.ecat.line_frames`), as the configuration maps them
(:func:`emulator.esc.chain.process_data_addresses`). A line of patches alone is the special case
of equal sizes: patch ``p``'s taxels at ``p x patch_bytes``.

Per cycle, the image holds the patches' taxels of that cycle and, for each ESI slave, its
inputs at that cycle's publication: cycle ``c`` (from 0) is publication ``c + 1``, every input
entry holding ``c + 1`` cut to its bits, or its value in an inputs file's row ``c + 1``
(:meth:`emulator.slave.esi_slave.EsiApplication.images`, what ``serve`` publishes).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.esc.chain import skin_devices
from emulator.esc.device import EscDevice
from emulator.slave.esi_slave import EsiApplication, EsiSlave, esi_device
from emulator.slave.sii import SyncManagerType

__all__ = ["EcatLine"]


class EcatLine:
    """``patches`` skin patches of ``patch_bytes``, then the ESI slaves ``esi``.

    Raises:
        TopologyError: an ESI slave the emulator cannot serve, or one with inputs on more than
            one SyncManager (the line reads one input buffer per slave).
    """

    def __init__(self, patches: int, patch_bytes: int, esi: Sequence[EsiSlave] = ()) -> None:
        self.patches, self.patch_bytes = patches, patch_bytes
        self.esi = tuple(esi)
        self._esi_devices = [esi_device(slave) for slave in self.esi]
        self._input_sms: list[int | None] = []
        for slave, dev in zip(self.esi, self._esi_devices, strict=True):
            info = dev.info
            sms = [
                i
                for i, sm in enumerate(info.sync_managers)
                if sm.type == SyncManagerType.INPUTS and info.sm_bytes(i)
            ]
            if len(sms) > 1:
                raise TopologyError(
                    f"--esi {slave.label}: inputs on SyncManagers {sms}; a simulated line reads "
                    "one input SyncManager per slave"
                )
            self._input_sms.append(sms[0] if sms else None)
        sizes = [patch_bytes] * patches + [dev.info.input_bytes for dev in self._esi_devices]
        self.input_sizes: tuple[int, ...] = tuple(sizes)
        self.image_bytes = sum(sizes)

    @property
    def nodes(self) -> int:
        """Slaves in the line."""
        return self.patches + len(self.esi)

    def devices(self, *, mailbox: bool = False) -> list[EscDevice]:
        """The ESCs in line order, powered on: new patches (``mailbox``: with CoE), then the ESI
        slaves (built once; the line reads their applications' input layouts)."""
        patches = skin_devices(self.patches, self.patch_bytes, mailbox=mailbox)
        return patches + self._esi_devices

    def image(
        self, cycles: npt.NDArray[np.int64], taxels: npt.NDArray[np.uint8]
    ) -> npt.NDArray[np.uint8]:
        """(k, image_bytes): the input image of cycles ``cycles`` (k of them) whose patches
        hold ``taxels`` (k, patches, patch_bytes)."""
        k = len(cycles)
        rows = taxels.reshape(k, self.patches * self.patch_bytes)
        if not self.esi:
            return rows
        parts = [rows]
        for dev, sm in zip(self._esi_devices, self._input_sms, strict=True):
            app = dev.app
            if sm is None or not isinstance(app, EsiApplication):
                continue
            parts.append(app.images(sm, cycles + 1))
        return np.concatenate(parts, axis=1)
