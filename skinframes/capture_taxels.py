"""From a capture to a taxel array: ``taxels_from_capture`` (vectorised, no per-frame objects).

Where the taxels sit (what the emulator writes, and what a master reading a skin sees):

- **EPL**: CN ``k`` (node id 1..239) sends its patch as the payload of its PRes
  (DS 301 4.6.1.1.4; byte ``12 * t + j`` is taxel j of triangle t, :mod:`skinframes.taxel`),
  valid only with the PRes flag RD set (the same clause: a CN sets it in NMT_CS_OPERATIONAL;
  before, while it boots, its payload is not valid data): a PRes with RD clear leaves the
  node's sample missing, as an EtherCAT datagram that returns unprocessed does, and so does a
  PRes whose payload (its size field, DS 301 4.6.1.1.4) holds fewer than the node's bytes.
  A sample is one cycle; it starts at the MN's SoC (DS 301 4.2.4.1).
- **EtherCAT**: node ``i`` (0-based position in the chain) owns ``bytes_per_node`` bytes at
  logical address ``base + i * bytes_per_node`` of the process image, read by LRD or LRW
  datagrams (ETG.1000.4 5.4.3): one datagram per slave (layout ``per-slave``) or a contiguous
  image cut into datagrams of up to 1486 bytes (layout ``logical``). Only datagrams that come
  back with a non-zero working counter carry data (the master's outgoing copy has 0). A sample
  starts where the master sends the datagram at the image's lowest address (working counter 0);
  a capture without the outgoing frames starts samples at the returned one.

Records are read in bulk (:mod:`skinframes.capture_arrays`) and every field is a numpy column:
the only Python loop walks datagram positions (at most as many steps as the longest chain of
datagrams in one frame).
"""

from __future__ import annotations

import os
import shutil
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Final, NamedTuple, TypeVar

import numpy as np
import numpy.typing as npt

from skinframes import ethercat, ethernet, taxel, vlan
from skinframes.atomic_file import atomic_output, check_target, create_temp
from skinframes.capture_arrays import (
    BLOCK_RECORDS,
    RecordArrays,
    iter_record_arrays,
    u16_at,
    u32_at,
)
from skinframes.errors import FieldRangeError
from skinframes.pcap import LINKTYPE_ETHERNET
from skinframes.powerlink.enums import MAX_CN_NODE_ID, MIN_CN_NODE_ID, MessageType, PResFlag
from skinframes.powerlink.schemas import (
    FLAGS1_OFFSET,
    PDO_HEADER_BYTES,
    PDO_SIZE_OFFSET,
    SRC_OFFSET,
)

__all__ = [
    "LAYOUTS",
    "CaptureTaxels",
    "TaxelStream",
    "TaxelSummary",
    "ecat_datagrams",
    "save_taxels",
    "taxels_from_capture",
]

LAYOUTS: Final = (
    "per-slave",
    "logical",
)  # as emulator.net.ecat.LAYOUTS (skinframes cannot import it)
TAXEL_COMMANDS: Final = (int(ethercat.Command.LRD), int(ethercat.Command.LRW))
ETHERTYPE_VLAN: Final = 0x8100  # IEEE 802.1Q tag: 4 bytes before the real EtherType
VLAN_TAG_BYTES: Final = 4
_ETHERTYPE_AT: Final = 2 * ethernet.MAC_BYTES  # 12


class CaptureTaxels(NamedTuple):
    """The taxels of a capture, sample by sample.

    Attributes:
        taxels: (samples, nodes, 16, 12) uint8; zeros where a node's data is missing or where a
            payload is shorter than a patch (192 bytes; longer ones are cut to 192).
        time_ns: (samples,) int64, the capture time of the frame that opened each sample
            (EPL: the SoC; EtherCAT: the master's frame with the image's first datagram).
        present: (samples, nodes) bool, whether the node's payload was in the capture.
    """

    taxels: npt.NDArray[np.uint8]
    time_ns: npt.NDArray[np.int64]
    present: npt.NDArray[np.bool_]


def taxels_from_capture(
    path: str | Path,
    *,
    nodes: int | None = None,
    bytes_per_node: int | None = None,
    layout: str | None = None,
    protocol: str | None = None,
) -> CaptureTaxels:
    """Every sample of skin taxels in a pcap/pcapng (gzip too) as one numpy array.

    Args:
        path: the capture.
        nodes: EPL CNs (node ids 1..nodes) or EtherCAT slaves; default: inferred (EPL the
            highest CN id that sent a PRes, EtherCAT the image size / ``bytes_per_node``).
        bytes_per_node: payload bytes per node; default: inferred (EPL the most common PRes
            Size, EtherCAT ``per-slave`` the most common datagram length, ``logical`` 192).
        layout: EtherCAT ``per-slave`` or ``logical``; default: ``per-slave`` when a sample has
            several taxel datagrams of one length (not 1486), else ``logical``.
        protocol: ``epl`` or ``ecat``; default: the one with more frames in the capture.

    Returns:
        :class:`CaptureTaxels` (taxels, time_ns, present).

    Raises:
        PcapFormatError: not a readable capture.
        FieldRangeError: a bad argument, or nothing to read taxels from.
    """
    stream = TaxelStream(
        path, nodes=nodes, bytes_per_node=bytes_per_node, layout=layout, protocol=protocol
    )
    parts = list(stream.chunks())
    return CaptureTaxels(*(np.concatenate([p[i] for p in parts]) for i in range(3)))


class TaxelSummary(NamedTuple):
    """What :func:`save_taxels` wrote: samples, nodes, and node samples missing."""

    samples: int
    nodes: int
    missing: int


def save_taxels(stream: TaxelStream, out: str | Path) -> TaxelSummary:
    """Write the taxels of ``stream`` to ``out``: ``.npy`` the (samples, nodes, 16, 12) uint8
    array, ``.npz`` also ``time_ns`` and ``present`` (``numpy.savez``'s names and layout).

    The taxels go to a scratch file beside ``out`` as their chunks come, then behind the
    header once their number is known: memory holds a chunk, the times (8 bytes a sample) and
    the presence (a byte per node and sample). ``out`` appears whole or not at all.

    Raises:
        FieldRangeError: not one node sample is present (no samples, or every one missing):
            nothing is written.
        CaptureError: ``out`` is refused (see :mod:`skinframes.atomic_file`).
    """
    target = Path(out)
    check_target(target)
    scratch, fd = create_temp(target)
    times: list[npt.NDArray[np.int64]] = []
    present: list[npt.NDArray[np.bool_]] = []
    samples = 0
    try:
        with os.fdopen(fd, "wb") as f:
            for part in stream.chunks():
                f.write(np.ascontiguousarray(part.taxels).data)
                times.append(part.time_ns)
                present.append(part.present)
                samples += part.taxels.shape[0]
        shape = (samples, stream.nodes, taxel.TRIANGLES_PER_PATCH, taxel.TAXELS_PER_TRIANGLE)
        header = {"descr": "|u1", "fortran_order": False, "shape": shape}
        seen = np.concatenate(present) if present else np.zeros((0, stream.nodes), dtype=bool)
        if not seen.any():  # an array of nothing but missing samples is no result: say so
            raise FieldRangeError(
                f"{stream.name}: no skin taxels: {samples} samples of {stream.nodes} nodes x "
                f"{stream.bytes_per_node} bytes ({stream.protocol}, {stream.layout}), not one "
                "node sample present; nothing written (--nodes, --bytes, --layout say where "
                "the taxels are)"
            )
        with atomic_output(target) as f, open(scratch, "rb") as raw:
            if target.suffix == ".npz":
                with zipfile.ZipFile(f, "w", zipfile.ZIP_STORED, allowZip64=True) as z:
                    with z.open("taxels.npy", "w", force_zip64=True) as member:
                        np.lib.format.write_array_header_1_0(member, header)
                        shutil.copyfileobj(raw, member, _COPY_BYTES)
                    for name, array in (("time_ns", np.concatenate(times)), ("present", seen)):
                        with z.open(f"{name}.npy", "w", force_zip64=True) as member:
                            np.lib.format.write_array(member, array)
            else:
                np.lib.format.write_array_header_1_0(f, header)
                shutil.copyfileobj(raw, f, _COPY_BYTES)
    finally:
        scratch.unlink(missing_ok=True)
    return TaxelSummary(samples, stream.nodes, int(seen.size - np.count_nonzero(seen)))


_COPY_BYTES: Final = 8 << 20


class TaxelStream:
    """:func:`taxels_from_capture` in chunks of samples, in memory that does not grow with the
    capture: a first pass over its records (:func:`~skinframes.capture_arrays.
    iter_record_arrays`, block by block) decides what :func:`taxels_from_capture` infers
    (``protocol``, ``nodes``, ``bytes_per_node``, ``layout``, where samples start);
    :meth:`chunks` reads it again and hands out the samples as they complete.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        nodes: int | None = None,
        bytes_per_node: int | None = None,
        layout: str | None = None,
        protocol: str | None = None,
        block_records: int = BLOCK_RECORDS,
    ) -> None:
        if layout is not None and layout not in LAYOUTS:
            raise FieldRangeError(f"layout {layout!r}; choose from {list(LAYOUTS)}", field="layout")
        if nodes is not None and nodes < 1:
            raise FieldRangeError(f"nodes {nodes}, need >= 1", field="nodes")
        if bytes_per_node is not None and bytes_per_node < 1:
            raise FieldRangeError(f"bytes_per_node {bytes_per_node}, need >= 1", field="bytes")
        if protocol not in (None, "epl", "ecat"):
            raise FieldRangeError(f"protocol {protocol!r}; choose epl or ecat", field="protocol")
        self.path, self._block = path, block_records
        epl, ecat = _EplSurvey(nodes), _EcatSurvey()
        records = 0
        for rec in iter_record_arrays(path, block_records):
            records += len(rec)
            payload, ethertype = _ethernet(rec)
            if protocol in (None, "epl"):
                epl.see(rec, payload, ethertype)
            if protocol in (None, "ecat"):
                ecat.see(rec, payload, ethertype)
        self._name = f"capture of {records} records"
        self.name = self._name  # how messages name the capture
        if protocol is None:
            protocol = "epl" if epl.frames >= ecat.frames else "ecat"
        self.protocol = protocol
        if protocol == "epl":
            self.nodes, self.bytes_per_node = epl.decide(self._name, nodes, bytes_per_node)
            self.layout = "per-slave"
            self._epl = epl
        else:
            self._base, self._image = ecat.extent(self._name)
            first, sent = _ecat_first_sample(path, block_records, self._base, layout is None)
            self._sent = sent
            self.layout, self.bytes_per_node, self.nodes = ecat.decide(
                first, self._image, nodes, bytes_per_node, layout
            )

    def chunks(self) -> Iterator[CaptureTaxels]:
        """The samples in capture order, a chunk (the samples completed by a block of records)
        at a time: the second pass."""
        out = _Samples(self.nodes, self.bytes_per_node, self._image_bytes())
        for rec in iter_record_arrays(self.path, self._block):
            payload, ethertype = _ethernet(rec)
            if self.protocol == "epl":
                mine = np.flatnonzero(ethertype == ethernet.ETHERTYPE_EPL)
                self._epl_block(out, rec, mine, payload[mine])
            else:
                mine = np.flatnonzero(ethertype == ethernet.ETHERTYPE_ECAT)
                self._ecat_block(out, rec, mine, payload[mine])
            done = out.flush(final=False)
            if done is not None:
                yield done
        last = out.flush(final=True)
        if last is not None:
            yield last
        elif not out.handed_out:
            yield out.empty()

    def _image_bytes(self) -> int | None:
        return self._image if self.protocol == "ecat" and self.layout == "logical" else None

    def _epl_block(
        self,
        out: _Samples,
        rec: RecordArrays,
        rows: npt.NDArray[np.int64],
        at: npt.NDArray[np.int64],
    ) -> None:
        soc, pres, src, size, payload_at = _epl_fields(rec, rows, at)
        pres &= src <= self.nodes
        markers = soc if self._epl.soc else pres & (src == self._epl.first_src)
        flags = rec.data[np.where(pres, payload_at - PDO_HEADER_BYTES + FLAGS1_OFFSET, 0)]
        ready = (flags & PResFlag.RD) != 0  # the payload is valid data only then
        out.place(
            rec.time_ns[rows],
            markers,
            pres & ready,
            src - 1,
            payload_at,
            np.minimum(size, self.bytes_per_node),
            rec.data,
        )

    def _ecat_block(
        self,
        out: _Samples,
        rec: RecordArrays,
        rows: npt.NDArray[np.int64],
        at: npt.NDArray[np.int64],
    ) -> None:
        data = rec.data
        end = rec.offset[rows] + rec.length[rows]
        dg = ecat_datagrams(data, at, end)
        logical = np.isin(dg["cmd"], TAXEL_COMMANDS) & (dg["length"] > 0)
        returned = logical & (dg["wkc"] > 0)
        lad, length, base = dg["lad"], dg["length"], self._base
        sent = logical & (dg["wkc"] == 0) & (lad == base)
        markers = sent if self._sent else returned & (lad == base)
        time_ns = rec.time_ns[rows][dg["frame"]]
        if self.layout == "per-slave":
            bpn = self.bytes_per_node
            node = (lad - base) // bpn
            carries = returned & ((lad - base) % bpn == 0) & (node < self.nodes)
            out.place(time_ns, markers, carries, node, dg["data_at"], np.minimum(length, bpn), data)
        else:
            out.scatter(time_ns, markers, returned, lad - base, length, dg["data_at"], data)


def _ethernet(rec: RecordArrays) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """(offset of the bytes after the EtherType, EtherType) per record; -1 for non-Ethernet.

    VLAN tags are looked through, stacked ones too (IEEE 802.1Q C-tags, 802.1ad S-tags and the
    old Q-in-Q TPID, :data:`skinframes.vlan.TPIDS`, as Wireshark dissects them).
    """
    ok = (rec.linktype == LINKTYPE_ETHERNET) & (rec.length >= ethernet.HEADER_BYTES)
    at = np.where(ok, rec.offset + _ETHERTYPE_AT, 0)
    ethertype = np.where(ok, u16_at(rec.data, at, big=True), -1)
    payload = rec.offset + ethernet.HEADER_BYTES
    end = rec.offset + rec.length
    tpids = np.array(sorted(vlan.TPIDS), np.int64)
    tagged = np.isin(ethertype, tpids) & (payload + VLAN_TAG_BYTES <= end)
    while bool(tagged.any()):  # one tag more each time, within the record: it ends
        at = np.where(tagged, at + VLAN_TAG_BYTES, at)
        ethertype = np.where(tagged, u16_at(rec.data, np.where(tagged, at, 0), big=True), ethertype)
        payload = np.where(tagged, payload + VLAN_TAG_BYTES, payload)
        tagged &= np.isin(ethertype, tpids) & (payload + VLAN_TAG_BYTES <= end)
    return payload, ethertype


class _EplSurvey:
    """What the first pass learns of the EPL frames."""

    def __init__(self, nodes: int | None) -> None:
        self.frames = 0
        self.pres = False
        self.soc = False
        self.max_src = 0
        self.first_src = MAX_CN_NODE_ID + 1  # the lowest CN id that sent a PRes (within nodes)
        self.sizes = np.zeros(1 << 16, dtype=np.int64)  # PRes Size histogram
        self._nodes = nodes

    def see(
        self, rec: RecordArrays, payload: npt.NDArray[np.int64], ethertype: npt.NDArray[np.int64]
    ) -> None:
        rows = np.flatnonzero(ethertype == ethernet.ETHERTYPE_EPL)
        self.frames += int(rows.shape[0])
        soc, pres, src, size, _ = _epl_fields(rec, rows, payload[rows])
        self.soc = self.soc or bool(soc.any())
        if not bool(pres.any()):
            return
        self.pres = True
        self.max_src = max(self.max_src, int(src[pres].max()))
        self.sizes += np.bincount(size[pres], minlength=1 << 16)
        within = pres & (src <= (self._nodes or MAX_CN_NODE_ID))
        if bool(within.any()):
            self.first_src = min(self.first_src, int(src[within].min()))

    def decide(self, name: str, nodes: int | None, bytes_per_node: int | None) -> tuple[int, int]:
        if not self.pres:
            raise FieldRangeError(f"{name}: no EPL PRes from a CN in the capture")
        if not self.soc and self.first_src > (nodes or MAX_CN_NODE_ID):
            raise FieldRangeError(f"{name}: no EPL PRes from CNs 1..{nodes} and no SoC")
        return (
            nodes if nodes is not None else self.max_src,
            bytes_per_node if bytes_per_node is not None else int(np.argmax(self.sizes)),
        )


class _EcatSurvey:
    """What the first pass learns of the EtherCAT frames."""

    def __init__(self) -> None:
        self.frames = 0
        self.base: int | None = None  # the lowest address a taxel datagram came back from
        self.end = 0  # the highest address + 1
        self.lengths = np.zeros(ethercat.MAX_DATAGRAM_DATA_BYTES + 1, dtype=np.int64)

    def see(
        self, rec: RecordArrays, payload: npt.NDArray[np.int64], ethertype: npt.NDArray[np.int64]
    ) -> None:
        rows = np.flatnonzero(ethertype == ethernet.ETHERTYPE_ECAT)
        self.frames += int(rows.shape[0])
        if not rows.size:
            return
        dg = ecat_datagrams(rec.data, payload[rows], rec.offset[rows] + rec.length[rows])
        logical = np.isin(dg["cmd"], TAXEL_COMMANDS) & (dg["length"] > 0)
        returned = logical & (dg["wkc"] > 0)
        if not bool(returned.any()):
            return
        lad, length = dg["lad"][returned], dg["length"][returned]
        low = int(lad.min())
        self.base = low if self.base is None else min(self.base, low)
        self.end = max(self.end, int((lad + length).max()))
        self.lengths += np.bincount(length, minlength=self.lengths.shape[0])

    def extent(self, name: str) -> tuple[int, int]:
        """(base, image bytes), or FieldRangeError without a taxel datagram."""
        if self.base is None:
            raise FieldRangeError(f"{name}: no LRD/LRW datagram came back with a working counter")
        return self.base, self.end - self.base

    def decide(
        self,
        first: int,
        image: int,
        nodes: int | None,
        bytes_per_node: int | None,
        layout: str | None,
    ) -> tuple[str, int, int]:
        """(layout, bytes_per_node, nodes) as :func:`taxels_from_capture` infers them."""
        seen = np.flatnonzero(self.lengths)
        if layout is None:
            one_length = seen.shape[0] == 1
            per_slave = (
                first > 1 and one_length and int(seen[0]) != ethercat.MAX_DATAGRAM_DATA_BYTES
            )
            layout = "per-slave" if per_slave else "logical"
        if bytes_per_node is None:
            if nodes is not None:
                bytes_per_node = -(-image // nodes)
            elif layout == "per-slave":
                bytes_per_node = int(np.argmax(self.lengths))
            else:
                bytes_per_node = taxel.PATCH_BYTES
        if nodes is None:
            nodes = -(-image // bytes_per_node)
        return layout, bytes_per_node, nodes


def _ecat_first_sample(
    path: str | Path, block_records: int, base: int, count: bool
) -> tuple[int, bool]:
    """(returned taxel datagrams from the first one at ``base`` up to the next one there, or
    all of them with fewer than two there; whether the master's own datagram at ``base`` is in
    the capture). Reads only as far as it must."""
    started = False  # the first returned datagram at base has been seen
    first = 0  # returned datagrams counted from it
    total = 0
    sent = False
    done = not count
    for rec in iter_record_arrays(path, block_records):
        payload, ethertype = _ethernet(rec)
        rows = np.flatnonzero(ethertype == ethernet.ETHERTYPE_ECAT)
        if not rows.size:
            continue
        dg = ecat_datagrams(rec.data, payload[rows], rec.offset[rows] + rec.length[rows])
        logical = np.isin(dg["cmd"], TAXEL_COMMANDS) & (dg["length"] > 0)
        at_base = dg["lad"] == base
        sent = sent or bool((logical & (dg["wkc"] == 0) & at_base).any())
        returned = logical & (dg["wkc"] > 0)
        if not done:
            ret_base = at_base[returned]
            total += int(ret_base.shape[0])
            hits = np.flatnonzero(ret_base).tolist()  # positions among the block's returned
            since = 0  # where this block's count starts
            if not started and hits:
                started, since, hits = True, hits[0], hits[1:]
            if started:
                end = hits[0] if hits else int(ret_base.shape[0])  # the next at base, or on
                first += end - since
                done = bool(hits)
        if done and sent:
            break
    return (first if done and count else total), sent


def _epl_fields(
    rec: RecordArrays, rows: npt.NDArray[np.int64], at: npt.NDArray[np.int64]
) -> tuple[
    npt.NDArray[np.bool_],
    npt.NDArray[np.bool_],
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
]:
    """(SoC, PRes from a CN, source node, payload size, payload offset) of EPL frames."""
    data = rec.data
    end = rec.offset[rows] + rec.length[rows]
    room = end - at
    mtype = np.where(room >= 1, data[np.where(room >= 1, at, 0)] & 0x7F, -1)
    soc = mtype == MessageType.SOC
    pres = (mtype == MessageType.PRES) & (room >= PDO_HEADER_BYTES)
    pres_at = np.where(pres, at, 0)
    src = np.where(pres, data[pres_at + SRC_OFFSET], 0).astype(np.int64)
    pres &= (src >= MIN_CN_NODE_ID) & (src <= MAX_CN_NODE_ID)
    size = np.where(pres, u16_at(data, pres_at + PDO_SIZE_OFFSET), 0)
    size = np.minimum(size, np.maximum(room - PDO_HEADER_BYTES, 0))  # a cut-off capture
    return soc, pres, src, size, pres_at + PDO_HEADER_BYTES


def rows_at(
    data: npt.NDArray[np.uint8],
    at: npt.NDArray[np.int64],
    width: int,
    count: npt.NDArray[np.int64],
) -> npt.NDArray[np.uint8]:
    """(len(at), width) bytes: row r is ``data[at[r] : at[r] + count[r]]``, zero-padded.

    Rows are gathered through a sliding-window view (one copy per row, no index per byte).
    """
    out = np.zeros((at.shape[0], width), dtype=np.uint8)
    inside = at + width <= data.shape[0]
    if data.shape[0] >= width:
        windows = np.lib.stride_tricks.sliding_window_view(data, width)
        out[inside] = windows[at[inside]]
    for r in np.flatnonzero(~inside):  # rows that end within ``width`` of the file's end
        tail = data[at[r] : at[r] + count[r]]
        out[r, : tail.shape[0]] = tail
    short = count < width
    if bool(short.any()):
        out[short] = np.where(np.arange(width) < count[short, None], out[short], 0)
    return out


def ecat_datagrams(
    data: npt.NDArray[np.uint8], at: npt.NDArray[np.int64], end: npt.NDArray[np.int64]
) -> dict[str, npt.NDArray[np.int64]]:
    """Every datagram of many EtherCAT frames at once (ETG.1000.4 Table 12/13).

    Args:
        data: the capture's bytes; ``at``: where each frame's EtherCAT header starts; ``end``:
            where its captured bytes end.

    Returns:
        Columns over all datagrams, in capture order (frame, then position): ``frame`` (index
        into ``at``), ``cmd``, ``idx``, ``lad`` (``adp | ado << 16``), ``length``, ``data_at``
        (offset of the data in ``data``), ``wkc``. The chain is read as :func:`ethercat.decode`
        reads it (while the previous M bit is set and bytes remain; header type 1 only); a
        datagram that runs past the frame ends its frame's chain.
    """
    n = at.shape[0]
    room = end - at
    header = np.where(room >= 2, u16_at(data, np.where(room >= 2, at, 0)), 0)
    active = (room >= 2) & (header >> 12 == ethercat.FrameType.ECAT)
    limit = np.minimum(end, at + ethercat.FRAME_HEADER_BYTES + (header & 0x7FF))
    cur = at + ethercat.FRAME_HEADER_BYTES
    frame_ids = np.arange(n)
    parts: list[tuple[npt.NDArray[np.int64], ...]] = []
    while True:
        active &= cur + ethercat.DATAGRAM_OVERHEAD_BYTES <= end
        live = np.flatnonzero(active)
        if not live.size:
            break
        c = cur[live]
        word = u16_at(data, c + 6)
        length = word & 0x7FF
        stop = c + ethercat.DATAGRAM_OVERHEAD_BYTES + length
        fits = stop <= end[live]
        live, c, word, length, stop = live[fits], c[fits], word[fits], length[fits], stop[fits]
        active[np.flatnonzero(active)[~fits]] = False
        if not live.size:
            break
        data_at = c + ethercat.DATAGRAM_HEADER_BYTES
        parts.append(
            (
                frame_ids[live],
                data[c].astype(np.int64),
                data[c + 1].astype(np.int64),
                u32_at(data, c + 2),
                length,
                data_at,
                u16_at(data, data_at + length),
            )
        )
        cur[live] = stop
        more = (word & 0x8000 != 0) & (stop < limit[live])
        active[live] = more
    names = ("frame", "cmd", "idx", "lad", "length", "data_at", "wkc")
    if not parts:
        return {k: np.zeros(0, dtype=np.int64) for k in names}
    cols = [np.concatenate([p[i] for p in parts]) for i in range(len(names))]
    # capture order: by frame, then by position in the frame (stable on the step order)
    order = np.argsort(cols[0], kind="stable")
    return {k: col[order] for k, col in zip(names, cols, strict=True)}


_MAX_PIECES: Final = 64  # distinct (address, length) pieces copied row-wise per block


class _Samples:
    """The samples being filled: those the current block of records opened, and the one before
    it that is still open (its items may follow in the next block). Items come in capture
    order; a sample opens at a marker that does not follow another marker directly (markers
    next to each other, as the two ports of a closed ring sending at once, open one sample);
    items before the first marker are left out. ``image``: the EtherCAT ``logical`` layout's
    image bytes (one image per sample, scattered by logical address), else None.
    """

    def __init__(self, nodes: int, bytes_per_node: int, image: int | None) -> None:
        self.nodes, self.bytes_per_node, self.image = nodes, bytes_per_node, image
        self.opened = 0  # samples opened so far
        self.first = 0  # the first sample still held
        self.last_marker = False  # the latest item was a marker
        self.handed_out = False
        size = nodes * bytes_per_node
        self._width = min(bytes_per_node, taxel.PATCH_BYTES)
        self._taxels = np.zeros((0, nodes, taxel.PATCH_BYTES), dtype=np.uint8)
        self._present = np.zeros((0, nodes), dtype=bool)
        self._image = np.zeros((0, size), dtype=np.uint8)
        self._seen = np.zeros((0, size), dtype=bool)
        self._times: list[npt.NDArray[np.int64]] = []

    def _open(
        self,
        time_ns: npt.NDArray[np.int64],
        markers: npt.NDArray[np.bool_],
        carries: npt.NDArray[np.bool_],
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """(carrying items, the row of each) of a block; new samples get their rows."""
        idx = np.flatnonzero(markers | carries)
        m = markers[idx]
        opens = m & ~np.concatenate(([self.last_marker], m[:-1]))
        if m.size:
            self.last_marker = bool(m[-1])
        sample = np.cumsum(opens) - 1 + self.opened
        new = int(np.count_nonzero(opens))
        self.opened += new
        self._times.append(time_ns[idx][opens].astype(np.int64))
        if self.image is None:
            self._taxels = _grow(self._taxels, new)
            self._present = _grow(self._present, new)
        else:
            self._image = _grow(self._image, new)
            seen = _grow(self._seen, new)
            seen[seen.shape[0] - new :, self.image :] = True  # past the image: nothing to read
            self._seen = seen
        use = carries[idx] & (sample >= 0)
        return idx[use], sample[use] - self.first

    def place(
        self,
        time_ns: npt.NDArray[np.int64],
        markers: npt.NDArray[np.bool_],
        carries: npt.NDArray[np.bool_],
        node: npt.NDArray[np.int64],
        payload_at: npt.NDArray[np.int64],
        count: npt.NDArray[np.int64],
        data: npt.NDArray[np.uint8],
    ) -> None:
        """Each carrying item's ``count`` bytes at ``payload_at`` into (its sample, node); an
        item with fewer bytes than the node's carries none (its sample stays missing, as one
        the EtherCAT image does not cover whole: no zeros stand in for bytes not sent)."""
        items, row = self._open(time_ns, markers, carries)
        whole = count[items] >= self.bytes_per_node
        items, row = items[whole], row[whole]
        n_of = node[items]
        c_of = np.minimum(count[items], taxel.PATCH_BYTES)
        self._present[row, n_of] = True
        if items.size:
            self._taxels[row, n_of, : self._width] = rows_at(
                data, payload_at[items], self._width, c_of
            )

    def scatter(
        self,
        time_ns: npt.NDArray[np.int64],
        markers: npt.NDArray[np.bool_],
        returned: npt.NDArray[np.bool_],
        address: npt.NDArray[np.int64],
        length: npt.NDArray[np.int64],
        data_at: npt.NDArray[np.int64],
        data: npt.NDArray[np.uint8],
    ) -> None:
        """Each returned datagram's bytes into its sample's image at its logical address.

        A cyclic capture reads the same few (address, length) pieces every sample: each piece's
        rows are copied at once; many different pieces go byte by byte.
        """
        items, row = self._open(time_ns, markers, returned)
        size = self._image.shape[1]
        lad = address[items]
        n = np.minimum(length[items], np.maximum(size - lad, 0))
        at = data_at[items]
        pieces, piece_of = np.unique(np.stack((lad, n)), axis=1, return_inverse=True)
        if pieces.shape[1] <= _MAX_PIECES:
            for p, (a, k) in enumerate(pieces.T.tolist()):
                mine = np.flatnonzero(piece_of.reshape(-1) == p)
                if k <= 0 or not mine.size:
                    continue
                count = np.full(mine.shape, k, dtype=np.int64)
                self._image[row[mine], a : a + k] = rows_at(data, at[mine], k, count)
                self._seen[row[mine], a : a + k] = True
        else:
            item_of = np.repeat(np.arange(items.size), n)  # one row per byte
            pos = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
            where = (row[item_of], lad[item_of] + pos)
            self._image[where] = data[at[item_of] + pos]
            self._seen[where] = True

    def flush(self, *, final: bool) -> CaptureTaxels | None:
        """The samples complete: all held but the open one, or (``final``) all of them."""
        held = self.opened - self.first
        k = held if final else held - 1
        if k <= 0:
            return None
        times = np.concatenate(self._times)
        self._times = [times[k:]]
        self.first += k
        self.handed_out = True
        shape = (k, self.nodes, taxel.TRIANGLES_PER_PATCH, taxel.TAXELS_PER_TRIANGLE)
        if self.image is None:
            taxels, self._taxels = self._taxels[:k], self._taxels[k:].copy()
            held_present, self._present = self._present[:k], self._present[k:].copy()
            return CaptureTaxels(taxels.reshape(shape), times[:k], held_present)
        image, self._image = self._image[:k], self._image[k:].copy()
        seen, self._seen = self._seen[:k], self._seen[k:].copy()
        bpn = self.bytes_per_node
        taxels = np.zeros((k, self.nodes, taxel.PATCH_BYTES), dtype=np.uint8)
        taxels[:, :, : self._width] = image.reshape(k, self.nodes, bpn)[:, :, : self._width]
        present: npt.NDArray[np.bool_] = np.all(seen.reshape(k, self.nodes, bpn), axis=2)
        return CaptureTaxels(taxels.reshape(shape), times[:k], present)

    def empty(self) -> CaptureTaxels:
        """No sample at all."""
        shape = (0, self.nodes, taxel.TRIANGLES_PER_PATCH, taxel.TAXELS_PER_TRIANGLE)
        return CaptureTaxels(
            np.zeros(shape, dtype=np.uint8),
            np.zeros(0, dtype=np.int64),
            np.zeros((0, self.nodes), dtype=bool),
        )


_A = TypeVar("_A", bound=np.generic)


def _grow(rows: npt.NDArray[_A], new: int) -> npt.NDArray[_A]:
    """``rows`` with ``new`` zero rows after them."""
    if not new:
        return rows
    return np.concatenate((rows, np.zeros((new, *rows.shape[1:]), dtype=rows.dtype)))
