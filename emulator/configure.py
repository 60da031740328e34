"""What a master sends to take a line of slaves to OP: the frames of a plain start-up.

Station addresses, mailbox and process-data SyncManagers and their FMMUs, then the AL states
(ETG.1000.6 5.4, 6.4; SOEM's ``ecx_config_init`` and ``ecx_config_map_group`` in essence). The
emulated chain (:mod:`emulator.esc.chain`, which re-exports these names) and the timed start-up
(:mod:`emulator.net.startup`) use them; they are the master's side of the wire, not the ESC's.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import replace
from typing import Final

import numpy as np

from emulator.errors import TopologyError
from emulator.esc.registers import FMMU_BYTES, REG_FMMU
from emulator.slave.sii import SlaveInfo, SyncManagerType
from emulator.slave.state_machine import AlState
from skinframes import ethercat
from skinframes.ethercat import Command, Datagram, EcatFrame

__all__ = [
    "STATION_BASE",
    "configure_frames",
    "configure_line_frames",
    "process_data_addresses",
    "process_data_writes",
]

STATION_BASE: Final = 0x1001  # configured station address of position 0 (SOEM, ethercrab)
_U16 = struct.Struct("<H")


def process_data_writes(info: SlaveInfo, inputs_at: int, outputs_at: int) -> list[Datagram]:
    """The register writes (ADP 0, to be addressed) that map a slave's process data, as a
    master's configuration writes them (ETG.1000.6 5.4, SOEM ``ecx_config_map_group``): each
    SyncManager of inputs, then of outputs, with the bytes of its PDOs (:meth:`SlaveInfo.sm_bytes`;
    one without PDOs is left alone), each followed by an FMMU of its own (0x0600 + 16 x n, in
    that order) that maps it to the logical address ``inputs_at`` or ``outputs_at`` (and on)."""
    out: list[Datagram] = []
    fmmu_at = REG_FMMU
    at = {SyncManagerType.INPUTS: inputs_at, SyncManagerType.OUTPUTS: outputs_at}
    fmmu_type = {SyncManagerType.INPUTS: 0x01, SyncManagerType.OUTPUTS: 0x02}  # read, write
    for kind in (SyncManagerType.INPUTS, SyncManagerType.OUTPUTS):
        for i, sm in enumerate(info.sync_managers):
            size = info.sm_bytes(i)
            if sm.type != kind or not size:
                continue
            regs = struct.pack("<HHBBBB", sm.start, size, sm.control, 0, sm.enable, 0)
            out.append(Datagram(Command.FPWR, 0, 0x0800 + 8 * i, regs))
            fmmu = struct.pack(
                "<IHBBHBBBxxx", at[kind], size, 0, 7, sm.start, 0, fmmu_type[kind], 0x01
            )
            out.append(Datagram(Command.FPWR, 0, fmmu_at, fmmu))
            fmmu_at += FMMU_BYTES
            at[kind] += size
    return out


def process_data_addresses(
    infos: Sequence[SlaveInfo], logical_base: int = 0
) -> list[tuple[int, int]]:
    """(inputs, outputs) logical address of each slave: the inputs one after another from
    ``logical_base``, the outputs after the last input (what :func:`line_frames
    <emulator.net.ecat.line_frames>` reads)."""
    inputs = [info.input_bytes for info in infos]
    outputs = [info.output_bytes for info in infos]
    in_at = np.cumsum([logical_base, *inputs])
    out_at = np.cumsum([int(in_at[-1]), *outputs])
    return [(int(in_at[p]), int(out_at[p])) for p in range(len(infos))]


def configure_frames(
    info: SlaveInfo, nodes: int, logical_base: int = 0, station_base: int = STATION_BASE
) -> list[bytes]:
    """The frames a master sends to take ``nodes`` slaves described by ``info`` to OP
    (:func:`configure_line_frames` of a line of equal slaves)."""
    return configure_line_frames([info] * nodes, logical_base, station_base)


def configure_line_frames(
    infos: Sequence[SlaveInfo], logical_base: int = 0, station_base: int = STATION_BASE
) -> list[bytes]:
    """The frames a master sends to take the slaves ``infos`` describe, in line order, to OP.

    Station addresses by APWR, the mailbox SyncManagers (if the SII has them), the process-data
    SyncManagers and their FMMUs by FPWR (:func:`process_data_writes`, at
    :func:`process_data_addresses`), then BWR AL control INIT+ack, PREOP, SAFEOP, OP: the
    essential steps of ETG.1000.6's start-up (5.4, 6.4).
    """
    for info in infos:
        if info.sm_of_type(SyncManagerType.INPUTS) is None:
            raise TopologyError("configure: the slave has no input SyncManager")
    frames: list[Datagram] = []
    for p in range(len(infos)):
        frames.append(Datagram(Command.APWR, (-p) & 0xFFFF, 0x0010, _U16.pack(station_base + p)))
    frames.append(Datagram(Command.BWR, 0, 0x0120, _U16.pack(AlState.INIT | 0x10)))
    addresses = process_data_addresses(infos, logical_base)
    for p, info in enumerate(infos):
        station = station_base + p
        for i, mb in enumerate(info.sync_managers):  # mailbox SMs before PREOP (ETG.1000.6 5.6)
            if mb.type in (SyncManagerType.MAILBOX_OUT, SyncManagerType.MAILBOX_IN):
                regs = struct.pack("<HHBBBB", mb.start, mb.length, mb.control, 0, mb.enable, 0)
                frames.append(Datagram(Command.FPWR, station, 0x0800 + 8 * i, regs))
        frames += [replace(d, adp=station) for d in process_data_writes(info, *addresses[p])]
    for state in (AlState.PREOP, AlState.SAFEOP, AlState.OP):
        frames.append(Datagram(Command.BWR, 0, 0x0120, _U16.pack(state)))
    return [ethercat.frame(EcatFrame((d,))).to_bytes() for d in frames]
