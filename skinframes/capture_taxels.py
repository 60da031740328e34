"""From a capture to a taxel array: ``taxels_from_capture`` (vectorised, no per-frame objects).

Where the taxels sit (what the emulator writes, and what a master reading a skin sees):

- **EPL**: CN ``k`` (node id 1..239) sends its patch as the payload of its PRes
  (DS 301 4.6.1.1.4; byte ``12 * t + j`` is taxel j of triangle t, :mod:`skinframes.taxel`).
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

from pathlib import Path
from typing import Final, NamedTuple

import numpy as np
import numpy.typing as npt

from skinframes import ethercat, ethernet, taxel
from skinframes.capture_arrays import RecordArrays, read_record_arrays, u16_at, u32_at
from skinframes.errors import FieldRangeError
from skinframes.pcap import LINKTYPE_ETHERNET
from skinframes.powerlink.enums import MAX_CN_NODE_ID, MIN_CN_NODE_ID, MessageType
from skinframes.powerlink.schemas import PDO_HEADER_BYTES, PDO_SIZE_OFFSET, SRC_OFFSET

__all__ = ["LAYOUTS", "CaptureTaxels", "ecat_datagrams", "taxels_from_capture"]

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
    if layout is not None and layout not in LAYOUTS:
        raise FieldRangeError(f"layout {layout!r}; choose from {list(LAYOUTS)}", field="layout")
    if nodes is not None and nodes < 1:
        raise FieldRangeError(f"nodes {nodes}, need >= 1", field="nodes")
    if bytes_per_node is not None and bytes_per_node < 1:
        raise FieldRangeError(f"bytes_per_node {bytes_per_node}, need >= 1", field="bytes")
    rec = read_record_arrays(path)
    payload, ethertype = _ethernet(rec)
    if protocol is None:
        n_epl = int(np.count_nonzero(ethertype == ethernet.ETHERTYPE_EPL))
        n_ecat = int(np.count_nonzero(ethertype == ethernet.ETHERTYPE_ECAT))
        protocol = "epl" if n_epl >= n_ecat else "ecat"
    if protocol == "epl":
        mine = np.flatnonzero(ethertype == ethernet.ETHERTYPE_EPL)
        return _epl(rec, mine, payload[mine], nodes, bytes_per_node)
    if protocol == "ecat":
        mine = np.flatnonzero(ethertype == ethernet.ETHERTYPE_ECAT)
        return _ecat(rec, mine, payload[mine], nodes, bytes_per_node, layout)
    raise FieldRangeError(f"protocol {protocol!r}; choose epl or ecat", field="protocol")


def _ethernet(rec: RecordArrays) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """(offset of the bytes after the EtherType, EtherType) per record; -1 for non-Ethernet.

    One IEEE 802.1Q tag is looked through.
    """
    ok = (rec.linktype == LINKTYPE_ETHERNET) & (rec.length >= ethernet.HEADER_BYTES)
    at = np.where(ok, rec.offset + _ETHERTYPE_AT, 0)
    ethertype = np.where(ok, u16_at(rec.data, at, big=True), -1)
    payload = rec.offset + ethernet.HEADER_BYTES
    tagged = (ethertype == ETHERTYPE_VLAN) & (rec.length >= ethernet.HEADER_BYTES + VLAN_TAG_BYTES)
    if bool(tagged.any()):
        inner = u16_at(rec.data, np.where(tagged, at + VLAN_TAG_BYTES, 0), big=True)
        ethertype = np.where(tagged, inner, ethertype)
        payload = np.where(tagged, payload + VLAN_TAG_BYTES, payload)
    return payload, ethertype


def _epl(
    rec: RecordArrays,
    rows: npt.NDArray[np.int64],
    at: npt.NDArray[np.int64],
    nodes: int | None,
    bytes_per_node: int | None,
) -> CaptureTaxels:
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
    if not bool(pres.any()):
        raise FieldRangeError(f"{rec_name(rec)}: no EPL PRes from a CN in the capture")
    if nodes is None:
        nodes = int(src[pres].max())
    if bytes_per_node is None:
        bytes_per_node = _mode(size[pres])
    pres &= src <= nodes
    node = src - 1
    markers = soc if bool(soc.any()) else pres & (src == int(src[pres].min()))
    payload_at = pres_at + PDO_HEADER_BYTES
    return _assemble(
        rec.time_ns[rows],
        markers,
        pres,
        node,
        payload_at,
        np.minimum(size, bytes_per_node),
        data,
        nodes,
    )


def rec_name(rec: RecordArrays) -> str:
    """How errors name the capture."""
    return f"capture of {len(rec)} records"


def _mode(values: npt.NDArray[np.int64]) -> int:
    """The most common value (the smallest of equally common ones)."""
    uniq, counts = np.unique(values, return_counts=True)
    return int(uniq[int(np.argmax(counts))])


def _samples(
    time_ns: npt.NDArray[np.int64], markers: npt.NDArray[np.bool_], carries: npt.NDArray[np.bool_]
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """(carrying items, the sample of each, the time of each sample).

    Items are in capture order; a sample starts at a marker that does not follow another
    marker directly (markers next to each other, as the two ports of a closed ring sending
    at once, open one sample); items before the first marker are left out.
    """
    idx = np.flatnonzero(markers | carries)
    m = markers[idx]
    opens = m & ~np.concatenate(([False], m[:-1]))
    sample = np.cumsum(opens) - 1
    use = carries[idx] & (sample >= 0)
    return idx[use], sample[use], time_ns[idx][opens].astype(np.int64)


def _assemble(
    time_ns: npt.NDArray[np.int64],
    markers: npt.NDArray[np.bool_],
    carries: npt.NDArray[np.bool_],
    node: npt.NDArray[np.int64],
    payload_at: npt.NDArray[np.int64],
    count: npt.NDArray[np.int64],
    data: npt.NDArray[np.uint8],
    nodes: int,
) -> CaptureTaxels:
    """Place each carrying item's ``count`` bytes at ``payload_at`` into (sample, node)."""
    items, s_of, time_out = _samples(time_ns, markers, carries)
    samples = time_out.shape[0]
    n_of = node[items]
    c_of = np.minimum(count[items], taxel.PATCH_BYTES)
    taxels = np.zeros((samples, nodes, taxel.PATCH_BYTES), dtype=np.uint8)
    present = np.zeros((samples, nodes), dtype=bool)
    present[s_of, n_of] = True
    width = int(c_of.max()) if c_of.size else 0
    if width:
        taxels[s_of, n_of, :width] = rows_at(data, payload_at[items], width, c_of)
    shape = (samples, nodes, taxel.TRIANGLES_PER_PATCH, taxel.TAXELS_PER_TRIANGLE)
    return CaptureTaxels(taxels.reshape(shape), time_out, present)


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


def _ecat(
    rec: RecordArrays,
    rows: npt.NDArray[np.int64],
    at: npt.NDArray[np.int64],
    nodes: int | None,
    bytes_per_node: int | None,
    layout: str | None,
) -> CaptureTaxels:
    data = rec.data
    end = rec.offset[rows] + rec.length[rows]
    dg = ecat_datagrams(data, at, end)
    logical = np.isin(dg["cmd"], TAXEL_COMMANDS) & (dg["length"] > 0)
    returned = logical & (dg["wkc"] > 0)
    if not bool(returned.any()):
        raise FieldRangeError(
            f"{rec_name(rec)}: no LRD/LRW datagram came back with a working counter"
        )
    lad, length = dg["lad"], dg["length"]
    base = int(lad[returned].min())
    image = int((lad + length)[returned].max()) - base
    lengths = length[returned]
    if layout is None:
        first = _first_sample_count(dg, returned, base)
        one_length = bool(np.all(lengths == lengths[0]))
        per_slave = first > 1 and one_length and int(lengths[0]) != ethercat.MAX_DATAGRAM_DATA_BYTES
        layout = "per-slave" if per_slave else "logical"
    if bytes_per_node is None:
        if nodes is not None:
            bytes_per_node = -(-image // nodes)
        else:
            bytes_per_node = _mode(lengths) if layout == "per-slave" else taxel.PATCH_BYTES
    if nodes is None:
        nodes = -(-image // bytes_per_node)
    sent = logical & (dg["wkc"] == 0) & (lad == base)
    markers = sent if bool(sent.any()) else returned & (lad == base)
    time_ns = rec.time_ns[rows][dg["frame"]]
    if layout == "per-slave":
        node = (lad - base) // bytes_per_node
        carries = returned & ((lad - base) % bytes_per_node == 0) & (node < nodes)
        return _assemble(
            time_ns,
            markers,
            carries,
            node,
            dg["data_at"],
            np.minimum(length, bytes_per_node),
            data,
            nodes,
        )
    return _logical(time_ns, markers, returned, dg, base, image, data, nodes, bytes_per_node)


def _first_sample_count(
    dg: dict[str, npt.NDArray[np.int64]], returned: npt.NDArray[np.bool_], base: int
) -> int:
    """Returned taxel datagrams from the first one at ``base`` up to the next one there."""
    at_base = np.flatnonzero(returned & (dg["lad"] == base))
    ret = np.flatnonzero(returned)
    if at_base.size >= 2:
        return int(np.count_nonzero((ret >= at_base[0]) & (ret < at_base[1])))
    return int(ret.size)


_MAX_PIECES: Final = 64  # distinct (address, length) pieces copied row-wise in _logical


def _logical(
    time_ns: npt.NDArray[np.int64],
    markers: npt.NDArray[np.bool_],
    returned: npt.NDArray[np.bool_],
    dg: dict[str, npt.NDArray[np.int64]],
    base: int,
    image_bytes: int,
    data: npt.NDArray[np.uint8],
    nodes: int,
    bytes_per_node: int,
) -> CaptureTaxels:
    """One image per sample: scatter every returned datagram's bytes at its logical address.

    A node is present when every byte of its share of the image (up to the image's end, the
    highest address any datagram read) came back.
    """
    items, s_of, time_out = _samples(time_ns, markers, returned)
    samples = time_out.shape[0]
    size = nodes * bytes_per_node
    lad = dg["lad"][items] - base
    length = np.minimum(dg["length"][items], np.maximum(size - lad, 0))
    image = np.zeros((samples, size), dtype=np.uint8)
    seen = np.zeros((samples, size), dtype=bool)
    seen[:, image_bytes:] = True  # past the image: nothing to read
    data_at = dg["data_at"][items]
    # a cyclic capture reads the same few (address, length) pieces every sample: copy each
    # piece's rows at once; many different pieces go byte by byte
    pieces, piece_of = np.unique(np.stack((lad, length)), axis=1, return_inverse=True)
    if pieces.shape[1] <= _MAX_PIECES:
        for p, (at, n) in enumerate(pieces.T.tolist()):
            mine = np.flatnonzero(piece_of.reshape(-1) == p)
            if n <= 0 or not mine.size:
                continue
            count = np.full(mine.shape, n, dtype=np.int64)
            image[s_of[mine], at : at + n] = rows_at(data, data_at[mine], n, count)
            seen[s_of[mine], at : at + n] = True
    else:
        item_of = np.repeat(np.arange(items.size), length)  # one row per byte
        pos = np.arange(int(length.sum())) - np.repeat(np.cumsum(length) - length, length)
        where = (s_of[item_of], lad[item_of] + pos)
        image[where] = data[data_at[item_of] + pos]
        seen[where] = True
    width = min(bytes_per_node, taxel.PATCH_BYTES)
    taxels = np.zeros((samples, nodes, taxel.PATCH_BYTES), dtype=np.uint8)
    taxels[:, :, :width] = image.reshape(samples, nodes, bytes_per_node)[:, :, :width]
    present: npt.NDArray[np.bool_] = np.all(seen.reshape(samples, nodes, bytes_per_node), axis=2)
    shape = (samples, nodes, taxel.TRIANGLES_PER_PATCH, taxel.TAXELS_PER_TRIANGLE)
    return CaptureTaxels(taxels.reshape(shape), time_out, present)
