"""``simulate_ecat`` and ``simulate_epl``: one call from a network description to a result and,
optionally, a capture written as the cycles come."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.model.params import TimingParams
from emulator.model.units import PS_PER_NS, PS_PER_US
from emulator.net.ecat import EcatEngine
from emulator.net.epl import EplEngine
from emulator.net.faults import Fault
from emulator.net.result import SimResult
from emulator.net.run import Engine, Payloads, Sink, run
from emulator.net.startup import StartupRecord
from emulator.slave.esi_slave import EsiSlave, load_esi_slave
from skinframes.pcap import CaptureWriter
from skinframes.vlan import VlanTag

__all__ = ["CaptureSink", "estimated_capture_bytes", "simulate_ecat", "simulate_epl"]


class CaptureSink:
    """A :class:`emulator.net.run.Sink` onto a ``skinframes`` capture writer (ps -> ns)."""

    def __init__(self, writer: CaptureWriter) -> None:
        self.writer = writer

    def write(
        self, time_ps: int, frame: bytes, *, port: int, outbound: bool, comment: str | None
    ) -> None:
        self.writer.write(
            time_ps // PS_PER_NS,
            frame,
            port=port,
            outbound=outbound,
            crc_error=comment is not None,
            comment=comment,
        )

    def write_repeated(
        self,
        times_ps: npt.NDArray[np.int64],
        lengths: npt.NDArray[np.int64],
        template: npt.NDArray[np.uint8],
        *,
        ports: npt.NDArray[np.int64],
        outbound: npt.NDArray[np.bool_],
        fills: list[tuple[int, npt.NDArray[np.uint8]]],
    ) -> None:
        self.writer.write_repeated(
            times_ps // PS_PER_NS, lengths, template, ports=ports, outbound=outbound, fills=fills
        )


class _ByteCounter:
    """A binary stream that keeps only the number of bytes written to it; ``name`` is the file
    the capture writer names in its errors."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.count = 0

    def write(self, data: bytes | memoryview) -> int:
        self.count += len(data)
        return len(data)

    def flush(self) -> None:
        pass


def estimated_capture_bytes(
    one_cycle: Callable[..., object],
    cycles: int,
    *,
    fmt: str,
    ports: int,
    name: str | os.PathLike[str] = "-",
) -> tuple[int, int]:
    """The size of the capture a run of ``cycles`` cycles writes, estimated before it runs:
    ``one_cycle(cycles=1, sink=...)`` (a ``simulate_ecat``/``simulate_epl`` with its arguments
    bound) writes one cycle into a byte counter, as ``fmt`` with ``ports`` interfaces; an error
    of the capture writer names the file ``name`` (the one the run will write). Returns
    (the estimate, the bytes of the one cycle). A run with a start-up sequence carries it
    once, so the estimate overstates it."""
    counter = _ByteCounter(os.fspath(name))
    with CaptureWriter(counter, fmt=fmt, ports=ports) as writer:  # type: ignore[arg-type]
        one_cycle(cycles=1, sink=CaptureSink(writer))
    return counter.count * cycles, counter.count


def _execute(
    engine: Engine,
    params: TimingParams,
    cycles: int,
    *,
    seed: int,
    payloads: Payloads | None,
    pcap: str | os.PathLike[str] | None,
    sink: Sink | None,
    progress: Callable[[int], None] | None,
    fast: bool,
    every_cycle: bool,
    ports: int,
    prelude: list[StartupRecord] | None = None,
) -> tuple[SimResult, Any]:
    if pcap is not None and sink is not None:
        raise TopologyError("give a pcap path or a sink, not both")
    start_ps = 0
    if prelude:  # the start-up's frames, then the cycles one IFG after its last frame
        start_ps = prelude[-1].time_ps + prelude[-1].wire_ps + params.ifg_ps

    def write_prelude(out: Sink | None) -> None:
        for r in prelude or ():
            if out is not None:
                out.write(r.time_ps, r.frame, port=0, outbound=r.outbound, comment=None)

    if pcap is None:
        write_prelude(sink)
        return run(
            engine,
            cycles,
            params_name=params.name,
            sink=sink,
            seed=seed,
            payloads=payloads,
            progress=progress,
            fast=fast,
            every_cycle=every_cycle,
            start_ps=start_ps,
        )
    names = ["master port 0", "master port 1"][:ports]
    with CaptureWriter(
        pcap, ports=ports, port_names=names, if_speed_bps=params.link_rate_bps
    ) as writer:
        write_prelude(CaptureSink(writer))
        result, events = run(
            engine,
            cycles,
            params_name=params.name,
            sink=CaptureSink(writer),
            seed=seed,
            payloads=payloads,
            progress=progress,
            fast=fast,
            every_cycle=every_cycle,
            start_ps=start_ps,
        )
    result.pcap = os.fspath(pcap)
    return result, events


def _tags(vid: int | None) -> tuple[VlanTag, ...]:
    """One 802.1Q tag with VLAN id ``vid`` (0xFFF is reserved, IEEE 802.1Q-2018 Table 9-2)."""
    if vid is None:
        return ()
    if not 0 <= vid <= 0xFFE:
        raise TopologyError(f"VLAN id {vid}: 0..4094 (4095 is reserved)")
    return (VlanTag(vid),)


def simulate_ecat(
    nodes: int,
    data_bytes: int,
    params: TimingParams,
    *,
    closed_ring: bool | None = None,
    redundant: bool | None = None,
    layout: str = "per-slave",
    cycles: int = 4,
    seed: int = 0,
    payloads: Payloads | None = None,
    faults: tuple[Fault, ...] = (),
    pcap: str | os.PathLike[str] | None = None,
    sink: Sink | None = None,
    progress: Callable[[int], None] | None = None,
    fast: bool = True,
    every_cycle: bool = False,
    startup: bool = False,
    vlan: int | None = None,
    esi: Sequence[str | EsiSlave] = (),
) -> SimResult:
    """Emulate ``cycles`` EtherCAT cycles reading ``data_bytes`` of taxels from each of
    ``nodes`` skin patches, and the inputs of the slaves ``esi`` after them (see
    :mod:`emulator.net.ecat`).

    Args:
        closed_ring: the master's second port closes the ring (``redundant`` is its old name).
        layout: ``per-slave`` (one LRD per slave, the paper's) or ``logical``.
        payloads: (cycles, nodes, data_bytes) uint8 taxels to carry (e.g. a CAN log's
            samples), or an iterator of such arrays of consecutive cycles, taken as the cycles
            need them (a long log streamed); seeded contact patterns when None.
        faults: the fault plan.
        pcap: write the frames at the master's port(s) to this capture as they come (pcap, or
            pcapng by its suffix: ports as interfaces, direction flags, marked bit errors).
        sink: receive the frames instead (e.g. :class:`emulator.net.run.MemorySink`).
        progress: called with the number of cycles done since the last call.
        fast: repeat steady cycles instead of walking each (the same bytes; a test proves it).
        every_cycle: list every cycle in ``details`` (walking each), not only the changes.
        startup: patches with a CoE mailbox, and the frames of the master's start-up
            (:mod:`emulator.net.startup`) before the first cycle; open ring, no faults.
        vlan: tag every frame with this 802.1Q VLAN id (0..4094); the 4 bytes count on the
            wire.
        esi: slaves as ESI files describe them, after the patches: ``ESI.xml[#TYPE]`` or
            loaded (:func:`emulator.slave.esi_slave.load_esi_slave`); their inputs count the
            cycles (:mod:`emulator.net.ecat_line`). ``nodes`` may be 0 with them.
    """
    if closed_ring is not None and redundant is not None and closed_ring != redundant:
        raise TopologyError("closed_ring and its old name redundant disagree")
    ring = bool(closed_ring if closed_ring is not None else redundant)
    engine = EcatEngine(
        nodes,
        data_bytes,
        params,
        closed_ring=ring,
        layout=layout,
        faults=faults,
        seed=seed,
        startup=startup,
        tags=_tags(vlan),
        esi=tuple(load_esi_slave(e) if isinstance(e, str) else e for e in esi),
    )
    result, events = _execute(
        engine,
        params,
        cycles,
        seed=seed,
        payloads=payloads,
        pcap=pcap,
        sink=sink,
        progress=progress,
        fast=fast,
        every_cycle=every_cycle,
        ports=2 if ring else 1,
        prelude=engine.startup,
    )
    if startup:
        s = engine.startup
        result.startup_us = (s[-1].time_ps + s[-1].wire_ps) / PS_PER_US if s else 0.0
        result.startup_frames = len(s)
    if ring and engine.break_ps:
        result.recovery_us = params.ecat_link_loss_ps / PS_PER_US
    result.diagnosis = engine.diagnosis(events)
    return result


def simulate_epl(
    nodes: int,
    data_bytes: int,
    params: TimingParams,
    *,
    cycles: int = 4,
    seed: int = 0,
    payloads: Payloads | None = None,
    asnd: bool = False,
    pres_timeout_ps: int | None = None,
    faults: tuple[Fault, ...] = (),
    pcap: str | os.PathLike[str] | None = None,
    sink: Sink | None = None,
    progress: Callable[[int], None] | None = None,
    fast: bool = True,
    every_cycle: bool = False,
    vlan: int | None = None,
) -> SimResult:
    """Emulate ``cycles`` EPL cycles: ``nodes`` CNs each answering with ``data_bytes`` of
    taxels (see :mod:`emulator.net.epl`; the other arguments as for :func:`simulate_ecat`).

    Args:
        asnd: each SoA invites one CN in turn, which answers with a StatusResponse.
        pres_timeout_ps: the MN's PRes timeout; a CN that cannot meet it loses its PRes.
        vlan: tag every frame with this 802.1Q VLAN id, as for :func:`simulate_ecat`.
    """
    engine = EplEngine(
        nodes,
        data_bytes,
        params,
        asnd=asnd,
        pres_timeout_ps=pres_timeout_ps,
        faults=faults,
        seed=seed,
        tags=_tags(vlan),
    )
    result, events = _execute(
        engine,
        params,
        cycles,
        seed=seed,
        payloads=payloads,
        pcap=pcap,
        sink=sink,
        progress=progress,
        fast=fast,
        every_cycle=every_cycle,
        ports=1,
    )
    result.diagnosis = engine.diagnosis(events, result.cycles)
    return result
