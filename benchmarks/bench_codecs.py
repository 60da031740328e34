"""Build and parse throughput of EtherCAT and EPL PRes frames: scapy, construct, skinframes.

Run from the repository root::

    python benchmarks/bench_codecs.py [--quick]

Workloads (the anchors of the performance reference, see benchmarks/README.md):

* EtherCAT: Ethernet II + 2-byte EtherCAT header + 7 datagrams, alternating LRD / APRD, each
  10-byte header + 192 data bytes + 2-byte WKC: 1444-byte frames.
* EPL PRes: Ethernet II + 10-byte PRes header + 192-byte payload: 216-byte frames.

The corpus is 100,000 frames per protocol; payloads, ``idx`` and the PRes source node change from
frame to frame (seeded RNG). Variants: scapy, plain construct (skinframes' schemas of record),
skinframes per frame (models), skinframes struct fast path, skinframes numpy batch.

Method: one process. Before any timing every encoder must produce byte-identical frames and every
decoder the same fields as the inputs, else the script aborts (exit 1). Each round runs every
variant once, in an order that rotates from round to round; gc is collected before and disabled
inside each timed region. Per-frame variants time a prefix of the corpus sized to about 1 s
(0.2 s with ``--quick``); batch variants always process the whole corpus. Reported: median
frames/s over the rounds, the median of the per-round ratios to scapy and to construct (paired
within a round), and the real-time factor at 100 Mbit/s, where each frame also costs 4 B FCS,
8 B preamble + SFD and 12 B inter-frame gap on the wire.
"""

from __future__ import annotations

import argparse
import gc
import itertools
import os
import platform
import statistics
import struct
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np
import numpy.typing as npt

# Benchmark this checkout, not whatever copy of skinframes the interpreter may have installed.
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import construct as cs
import scapy
from scapy.config import conf

# scapy parses EtherCatLRD.data as a FieldListField of ByteFields; with the default limit of 100
# list items a 192-byte datagram is silently dissected as Raw, at a flattering speed.
conf.max_list_count = 4096

from scapy.contrib.ethercat import (  # noqa: E402
    EtherCat,
    EtherCatAPRD,
    EtherCatLRD,
    EtherCatType12DLPDU,
)
from scapy.fields import ByteField, LEFieldLenField, StrLenField  # noqa: E402
from scapy.layers.l2 import Ether  # noqa: E402
from scapy.packet import Packet, Raw, bind_layers  # noqa: E402

from skinframes import decode_frame, ethercat, ethernet, powerlink  # noqa: E402
from skinframes.ethercat import Command, Datagram, EcatFrame  # noqa: E402
from skinframes.powerlink import PRes  # noqa: E402

CORPUS_FRAMES: Final = 100_000
LINK_BITS_PER_S: Final = 100_000_000
# Per wire frame beyond the captured bytes: FCS, preamble + SFD, inter-frame gap (802.3).
WIRE_EXTRA_BYTES: Final = ethernet.FCS_BYTES + ethernet.PREAMBLE_SFD_BYTES + ethernet.IFG_BYTES
TARGET_BATCH: Final = 1000.0  # the targets, as ratios to scapy
TARGET_PER_FRAME_DECODE: Final = 100.0

FAMILIES: Final = ("scapy", "construct", "model", "struct", "numpy")
FAMILY_LABELS: Final = {
    "scapy": "scapy",
    "construct": "construct (schema of record)",
    "model": "skinframes per frame (models)",
    "struct": "skinframes struct fast path",
    "numpy": "skinframes numpy batch",
}


class Mismatch(SystemExit):
    """An encoder or decoder disagrees with the others: the figures would be meaningless."""

    def __init__(self, message: str) -> None:
        super().__init__(f"\nbench_codecs: VERIFICATION FAILED: {message}\nNo timing was done.")


# --- EtherCAT workload ----------------------------------------------------------------------------
ECAT_K: Final = 7
ECAT_SIZE: Final = 192
ECAT_CMDS: Final = tuple(Command.LRD if j % 2 == 0 else Command.APRD for j in range(ECAT_K))
# LRD: logical address 0x00010000 + 192 j; APRD: auto-increment position -j, register 0x1000.
ECAT_ADP: Final = tuple(j * ECAT_SIZE if j % 2 == 0 else (-j) & 0xFFFF for j in range(ECAT_K))
ECAT_ADO: Final = tuple(0x0001 if j % 2 == 0 else 0x1000 for j in range(ECAT_K))
ECAT_ADDRESSES: Final = tuple(adp | ado << 16 for adp, ado in zip(ECAT_ADP, ECAT_ADO, strict=True))
ECAT_WKC: Final = tuple(j + 1 for j in range(ECAT_K))  # as returned by the slaves
ECAT_LENGTH: Final = ECAT_K * (ethercat.DATAGRAM_OVERHEAD_BYTES + ECAT_SIZE)  # header length: 1428
ECAT_FRAME_BYTES: Final = ethernet.HEADER_BYTES + ethercat.FRAME_HEADER_BYTES + ECAT_LENGTH  # 1444
ECAT_HEADER_WORD: Final = ECAT_LENGTH | ethercat.FrameType.ECAT << 12
MASTER_MAC_TEXT: Final = ethernet.format_mac(ethercat.MASTER_MAC)
BROADCAST_MAC_TEXT: Final = ethernet.format_mac(ethercat.BROADCAST_MAC)

# One frame's input: per datagram (cmd, adp, ado, data, idx, wkc).
EcatInput = tuple[tuple[int, int, int, bytes, int, int], ...]
# What every EtherCAT decoder must report: Ethernet header, EtherCAT header length, and per
# datagram (cmd, idx, adp, ado, more, circulating, irq, data, wkc).
EcatFields = tuple[bytes, bytes, int, int, tuple[tuple[Any, ...], ...]]


@dataclass
class Workload:
    """One protocol's corpus, its variants and its results."""

    name: str
    title: str
    frame_bytes: int
    builders: dict[str, Callable[[Any], bytes]]  # family -> per-frame encoder (not numpy)
    parsers: dict[str, Callable[[bytes], Any]]  # family -> per-frame decoder (not numpy)
    build_labels: dict[str, str]
    parse_labels: dict[str, str]
    inputs: list[Any]  # per-frame encoder inputs
    frames: list[bytes]  # the reference frames, one bytes object each
    batch_build: Callable[[], npt.NDArray[np.uint8]]
    batch_parse: Callable[[], Any]
    struct_decoder: str  # the per-frame payload decoder, for the target lines
    fps: dict[tuple[str, str], list[float]] = field(default_factory=dict)
    timed_frames: dict[tuple[str, str], int] = field(default_factory=dict)

    @property
    def wire_fps(self) -> float:
        """Frames per second a saturated 100 Mbit/s link carries."""
        return LINK_BITS_PER_S / 8 / (self.frame_bytes + WIRE_EXTRA_BYTES)


def ecat_inputs(n: int, rng: np.random.Generator) -> tuple[npt.NDArray[np.uint8], list[EcatInput]]:
    """Random payloads (n, 7, 192) and the per-frame inputs derived from them."""
    data = rng.integers(0, 256, size=(n, ECAT_K, ECAT_SIZE), dtype=np.uint8)
    inputs: list[EcatInput] = []
    for i in range(n):
        row = data[i]
        inputs.append(
            tuple(
                (
                    ECAT_CMDS[j],
                    ECAT_ADP[j],
                    ECAT_ADO[j],
                    row[j].tobytes(),
                    (i * ECAT_K + j) & 0xFF,
                    ECAT_WKC[j],
                )
                for j in range(ECAT_K)
            )
        )
    return data, inputs


def ecat_build_scapy(dgs: EcatInput) -> bytes:
    """scapy as its documentation writes it: layers stacked with ``/``."""
    pkt = Ether(dst=BROADCAST_MAC_TEXT, src=MASTER_MAC_TEXT, type=0x88A4) / EtherCat(type=1)
    for cmd, adp, ado, data, idx, wkc in dgs:
        if cmd == Command.LRD:  # scapy models the logical address as one 32-bit field
            pkt = pkt / EtherCatLRD(idx=idx, adr=adp | ado << 16, data=list(data), wkc=wkc)
        else:
            pkt = pkt / EtherCatAPRD(idx=idx, adp=adp, ado=ado, data=list(data), wkc=wkc)
    return bytes(pkt)


ECAT_CONSTRUCT: Final = cs.Struct(
    "eth" / ethernet.header_schema,
    "ecat" / ethercat.frame_schema,
)


def ecat_build_construct(dgs: EcatInput) -> bytes:
    """construct: the schemas of record (ethernet.header_schema + ethercat.frame_schema)."""
    last = len(dgs) - 1
    return bytes(
        ECAT_CONSTRUCT.build(
            {
                "eth": {
                    "dst": ethercat.BROADCAST_MAC,
                    "src": ethercat.MASTER_MAC,
                    "ethertype": ethernet.ETHERTYPE_ECAT,
                },
                "ecat": {
                    "header": {"type": 1, "reserved": False, "length": ECAT_LENGTH},
                    "datagrams": [
                        {
                            "cmd": cmd,
                            "idx": idx,
                            "adp": adp,
                            "ado": ado,
                            "flags": {"more": j < last, "circulating": False, "reserved": 0},
                            "irq": 0,
                            "data": data,
                            "wkc": wkc,
                        }
                        for j, (cmd, adp, ado, data, idx, wkc) in enumerate(dgs)
                    ],
                },
            }
        )
    )


def ecat_build_model(dgs: EcatInput) -> bytes:
    """skinframes models: ``ethercat.frame(EcatFrame(...)).to_bytes()``."""
    datagrams = tuple(
        Datagram(cmd, adp, ado, data, idx, wkc=wkc) for cmd, adp, ado, data, idx, wkc in dgs
    )
    return ethercat.frame(EcatFrame(datagrams)).to_bytes()


_ECAT_HEAD: Final = struct.Struct("<6s6s2sH")  # dst src EtherType(big-endian bytes) header word
_ECAT_ETHERTYPE: Final = ethernet.ETHERTYPE_ECAT.to_bytes(2, "big")


def ecat_build_struct(dgs: EcatInput) -> bytes:
    """skinframes struct fast path: ``Datagram.to_bytes`` per datagram, headers by ``struct``."""
    last = len(dgs) - 1
    parts = [
        _ECAT_HEAD.pack(
            ethercat.BROADCAST_MAC, ethercat.MASTER_MAC, _ECAT_ETHERTYPE, ECAT_HEADER_WORD
        )
    ]
    parts += [
        Datagram(cmd, adp, ado, data, idx, wkc=wkc).to_bytes(more=j < last)
        for j, (cmd, adp, ado, data, idx, wkc) in enumerate(dgs)
    ]
    return b"".join(parts)


_ETH_HEAD: Final = struct.Struct(">6s6sH")


def ecat_parse_struct(frame: bytes) -> tuple[EcatFrame, int, Any]:
    """skinframes struct fast path: Ethernet header by ``struct``, then ``ethercat.decode``."""
    _ETH_HEAD.unpack_from(frame)
    return ethercat.decode(frame[ethernet.HEADER_BYTES :])


def ecat_fields_expected(dgs: EcatInput) -> EcatFields:
    """The fields every decoder must report for the frame built from ``dgs``."""
    last = len(dgs) - 1
    return (
        ethercat.BROADCAST_MAC,
        ethercat.MASTER_MAC,
        ethernet.ETHERTYPE_ECAT,
        ECAT_LENGTH,
        tuple(
            (cmd, idx, adp, ado, j < last, False, 0, data, wkc)
            for j, (cmd, adp, ado, data, idx, wkc) in enumerate(dgs)
        ),
    )


def ecat_fields_scapy(pkt: Any) -> EcatFields:
    """Fields of a scapy-dissected frame; no datagram may have become ``Raw``."""
    if Raw in pkt:
        raise Mismatch("scapy dissected EtherCAT datagrams as Raw (conf.max_list_count too low?)")
    ecat = pkt[EtherCat]
    out = []
    layer = ecat.payload
    while isinstance(layer, EtherCatType12DLPDU):
        if "adr" in layer.fields:
            adp, ado = layer.adr & 0xFFFF, layer.adr >> 16
        else:
            adp, ado = layer.adp, layer.ado
        out.append(
            (
                layer._cmd,
                layer.idx,
                adp,
                ado,
                bool(layer.next),
                bool(layer.c),
                layer.irq,
                bytes(layer.data),
                layer.wkc,
            )
        )
        layer = layer.payload
    return (
        ethernet.mac(pkt.dst),
        ethernet.mac(pkt.src),
        pkt.type,
        ecat.length,
        tuple(out),
    )


def ecat_fields_construct(c: Any) -> EcatFields:
    """Fields of a construct container."""
    dgs = tuple(
        (
            d.cmd,
            d.idx,
            d.adp,
            d.ado,
            d.flags.more,
            d.flags.circulating,
            d.irq,
            bytes(d.data),
            d.wkc,
        )
        for d in c.ecat.datagrams
    )
    return (c.eth.dst, c.eth.src, c.eth.ethertype, c.ecat.header.length, dgs)


def _ecat_fields(dst: bytes, src: bytes, ethertype: int, ecat: EcatFrame) -> EcatFields:
    last = len(ecat.datagrams) - 1
    dgs = tuple(
        (
            d.cmd,
            d.idx,
            d.adp,
            d.ado,
            (j < last) if d.more is None else d.more,
            d.circulating,
            d.irq,
            d.data,
            d.wkc,
        )
        for j, d in enumerate(ecat.datagrams)
    )
    length = ecat.datagram_bytes if ecat.length is None else ecat.length
    return (dst, src, ethertype, length, dgs)


def ecat_fields_model(frame: ethernet.EthernetFrame) -> EcatFields:
    """Fields of ``decode_frame``'s result."""
    if not isinstance(frame.payload, EcatFrame) or frame.findings:
        raise Mismatch(f"decode_frame: {frame.payload!r:.60} with findings {frame.findings}")
    assert frame.ethertype is not None
    return _ecat_fields(frame.dst, frame.src, frame.ethertype, frame.payload)


def ecat_fields_struct_for(frame_bytes: bytes) -> Callable[[Any], EcatFields]:
    """Fields of ``ethercat.decode``'s result (the Ethernet header comes from the raw frame)."""

    def fields_of(result: tuple[EcatFrame, int, Any]) -> EcatFields:
        ecat, used, findings = result
        if findings or used != ECAT_LENGTH + ethercat.FRAME_HEADER_BYTES:
            raise Mismatch(f"ethercat.decode: used {used} bytes, findings {findings}")
        dst, src, ethertype = _ETH_HEAD.unpack_from(frame_bytes)
        return _ecat_fields(dst, src, ethertype, ecat)

    return fields_of


def ecat_workload(n: int, rng: np.random.Generator, checked: int) -> Workload:
    """The EtherCAT corpus (the numpy batch makes the reference frames), verified.

    ``checked`` frames, spread over the corpus, verify the fast per-frame encoders.
    """
    data, inputs = ecat_inputs(n, rng)
    idx = (np.arange(n * ECAT_K, dtype=np.int64) & 0xFF).reshape(n, ECAT_K)
    addresses = np.asarray(ECAT_ADDRESSES, dtype=np.int64)
    wkc = np.asarray(ECAT_WKC, dtype=np.int64)

    def batch_build() -> npt.NDArray[np.uint8]:
        return ethercat.pack_frames_batch(ECAT_CMDS, addresses, data, idx=idx, wkc=wkc)

    batch = batch_build()
    frames = [row.tobytes() for row in batch]

    def batch_parse() -> Any:
        return ethercat.unpack_frames_batch(batch, ECAT_K, ECAT_SIZE)

    w = Workload(
        name="ecat",
        title=(
            f"EtherCAT: Ethernet + EtherCAT header + {ECAT_K} datagrams (LRD/APRD alternating, "
            f"{ECAT_SIZE} data bytes each) = {ECAT_FRAME_BYTES}-byte frame"
        ),
        frame_bytes=ECAT_FRAME_BYTES,
        builders={
            "scapy": ecat_build_scapy,
            "construct": ecat_build_construct,
            "model": ecat_build_model,
            "struct": ecat_build_struct,
        },
        parsers={
            "scapy": Ether,
            "construct": ECAT_CONSTRUCT.parse,
            "model": decode_frame,
            "struct": ecat_parse_struct,
        },
        build_labels={
            "scapy": "Ether()/EtherCat()/EtherCatLRD(..)/..; bytes()",
            "construct": "Struct(header_schema, frame_schema).build",
            "model": "ethercat.frame(EcatFrame(Datagram..)).to_bytes()",
            "struct": "Datagram(..).to_bytes(more=) x7 + struct header, join",
            "numpy": f"pack_frames_batch, {n:,} frames per call",
        },
        parse_labels={
            "scapy": "Ether(frame)",
            "construct": "Struct(header_schema, frame_schema).parse",
            "model": "decode_frame(frame)",
            "struct": "struct Ethernet header + ethercat.decode(frame[14:])",
            "numpy": "unpack_frames_batch on one (n, 1444) uint8 array",
        },
        inputs=inputs,
        frames=frames,
        batch_build=batch_build,
        batch_parse=batch_parse,
        struct_decoder="ethercat.decode(frame[14:])",
    )

    # Encoders: every per-frame encoder against the batch rows (the whole corpus for the fast
    # per-frame paths, a spread sample for scapy and construct, which would take minutes).
    if len(frames[0]) != ECAT_FRAME_BYTES:
        raise Mismatch(f"EtherCAT frame is {len(frames[0])} bytes, expected {ECAT_FRAME_BYTES}")
    for family, sample in (
        ("scapy", _sample(n, 40)),
        ("construct", _sample(n, 400)),
        ("model", _sample(n, 5000)),
        ("struct", _sample(n, checked)),
    ):
        _check_encoder(w, family, sample)
    # Decoders: against the inputs; the batch decoder on the whole corpus, vectorised.
    for family, sample, fields_of in (
        ("scapy", _sample(n, 40), ecat_fields_scapy),
        ("construct", _sample(n, 400), ecat_fields_construct),
        ("model", _sample(n, 5000), ecat_fields_model),
    ):
        _check_decoder(w, family, sample, fields_of, ecat_fields_expected)
    for i in _sample(n, 5000):
        got = ecat_fields_struct_for(frames[i])(ecat_parse_struct(frames[i]))
        if got != ecat_fields_expected(inputs[i]):
            raise Mismatch(f"EtherCAT struct decoder, frame {i}: {got!r:.200}")
    cmds, addr, payloads, wkcs = batch_parse()
    if not (
        np.array_equal(cmds, np.broadcast_to(np.asarray(ECAT_CMDS, dtype=np.uint8), (n, ECAT_K)))
        and np.array_equal(addr, np.broadcast_to(addresses, (n, ECAT_K)))
        and np.array_equal(payloads, data)
        and np.array_equal(wkcs, np.broadcast_to(wkc, (n, ECAT_K)))
    ):
        raise Mismatch("EtherCAT numpy batch decoder disagrees with the inputs")
    return w


# --- EPL PRes workload ----------------------------------------------------------------------------
EPL_SIZE: Final = 192
EPL_FRAME_BYTES: Final = ethernet.HEADER_BYTES + powerlink.PDO_HEADER_BYTES + EPL_SIZE  # 216
EPL_NMT: Final = powerlink.NmtState.OPERATIONAL
EPL_FLAGS1: Final = powerlink.PResFlag.RD
MAC_PRES_TEXT: Final = ethernet.format_mac(powerlink.MAC_PRES)

EplInput = tuple[int, bytes]  # (source node, payload)
# Ethernet header, then (type, dest, src, nmt_status, flags1, flags2, pdo_version, reserved_7,
# size, payload).
EplFields = tuple[Any, ...]


class EplPRes(Packet):
    """A minimal scapy layer for the EPL PRes (scapy has no POWERLINK layer); DS 301 4.6.1.1.4."""

    name = "EPL PRes"
    fields_desc = [  # noqa: RUF012 (scapy's declaration style)
        ByteField("mtyp", powerlink.MessageType.PRES),
        ByteField("dest", powerlink.BROADCAST_NODE_ID),
        ByteField("src", 0),
        ByteField("nmt_status", EPL_NMT),
        ByteField("flags1", EPL_FLAGS1),
        ByteField("flags2", 0),
        ByteField("pdo_version", 0),
        ByteField("reserved_7", 0),
        LEFieldLenField("size", None, length_of="data"),
        StrLenField("data", b"", length_from=lambda pkt: pkt.size),  # `payload` is scapy's
    ]


bind_layers(Ether, EplPRes, type=ethernet.ETHERTYPE_EPL)


def epl_build_scapy(inp: EplInput) -> bytes:
    """scapy: ``Ether()/EplPRes()``."""
    src, payload = inp
    pkt = Ether(dst=MAC_PRES_TEXT, src=f"02:00:00:00:0a:{src:02x}", type=0x88AB) / EplPRes(
        src=src, data=payload
    )
    return bytes(pkt)


EPL_CONSTRUCT: Final = cs.Struct(
    "eth" / ethernet.header_schema,
    "pres" / powerlink.pres_schema,
)


def epl_build_construct(inp: EplInput) -> bytes:
    """construct: ethernet.header_schema + powerlink.pres_schema."""
    src, payload = inp
    return bytes(
        EPL_CONSTRUCT.build(
            {
                "eth": {
                    "dst": powerlink.MAC_PRES,
                    "src": powerlink.node_mac(src),
                    "ethertype": ethernet.ETHERTYPE_EPL,
                },
                "pres": {
                    "message_type": powerlink.MessageType.PRES,
                    "dest": powerlink.BROADCAST_NODE_ID,
                    "src": src,
                    "nmt_status": EPL_NMT,
                    "flags1": EPL_FLAGS1,
                    "flags2": 0,
                    "pdo_version": 0,
                    "reserved_7": 0,
                    "payload": payload,
                },
            }
        )
    )


def epl_build_model(inp: EplInput) -> bytes:
    """skinframes models: ``powerlink.frame(PRes(...)).to_bytes()``."""
    src, payload = inp
    return powerlink.frame(PRes(src, payload)).to_bytes()


def epl_build_struct(inp: EplInput) -> bytes:
    """skinframes struct fast path: Ethernet header by ``struct`` + ``pack_pres``."""
    src, payload = inp
    head = _ETH_HEAD.pack(powerlink.MAC_PRES, powerlink.node_mac(src), ethernet.ETHERTYPE_EPL)
    return head + powerlink.pack_pres(src, payload)


def epl_parse_struct(frame: bytes) -> tuple[powerlink.EplMessage, int, Any]:
    """skinframes per-frame decoder without the Ethernet layer: ``powerlink.decode``."""
    _ETH_HEAD.unpack_from(frame)
    return powerlink.decode(frame[ethernet.HEADER_BYTES :])


def epl_fields_expected(inp: EplInput) -> EplFields:
    """The fields every decoder must report for the frame built from ``inp``."""
    src, payload = inp
    return (
        powerlink.MAC_PRES,
        powerlink.node_mac(src),
        ethernet.ETHERTYPE_EPL,
        powerlink.MessageType.PRES,
        powerlink.BROADCAST_NODE_ID,
        src,
        EPL_NMT,
        EPL_FLAGS1,
        0,
        0,
        0,
        len(payload),
        payload,
    )


def epl_fields_scapy(pkt: Any) -> EplFields:
    """Fields of a scapy-dissected PRes frame."""
    if EplPRes not in pkt or Raw in pkt:
        raise Mismatch(f"scapy did not dissect an EPL PRes: {pkt.summary()}")
    p = pkt[EplPRes]
    return (
        ethernet.mac(pkt.dst),
        ethernet.mac(pkt.src),
        pkt.type,
        *(p.getfieldval(name) for name in ("mtyp", "dest", "src", "nmt_status", "flags1")),
        *(p.getfieldval(name) for name in ("flags2", "pdo_version", "reserved_7", "size")),
        bytes(p.data),
    )


def epl_fields_construct(c: Any) -> EplFields:
    """Fields of a construct container."""
    p = c.pres
    return (
        c.eth.dst,
        c.eth.src,
        c.eth.ethertype,
        p.message_type,
        p.dest,
        p.src,
        p.nmt_status,
        p.flags1,
        p.flags2,
        p.pdo_version,
        p.reserved_7,
        p.size,
        bytes(p.payload),
    )


def _epl_fields(dst: bytes, src: bytes, ethertype: int, m: Any) -> EplFields:
    if not isinstance(m, PRes):
        raise Mismatch(f"EPL decoder returned {m!r:.80}, not a PRes")
    return (
        dst,
        src,
        ethertype,
        m.MESSAGE_TYPE,
        m.dest,
        m.src,
        m.nmt_status,
        m.flags1,
        m.flags2,
        m.pdo_version,
        m.reserved_7,
        m.size,
        m.payload,
    )


def epl_fields_model(frame: ethernet.EthernetFrame) -> EplFields:
    """Fields of ``decode_frame``'s result."""
    if frame.findings:
        raise Mismatch(f"decode_frame: findings {frame.findings}")
    assert frame.ethertype is not None
    return _epl_fields(frame.dst, frame.src, frame.ethertype, frame.payload)


def epl_workload(n: int, rng: np.random.Generator, checked: int) -> Workload:
    """The EPL PRes corpus (the numpy batch makes the reference frames), verified.

    ``checked`` frames, spread over the corpus, verify the fast per-frame encoders.
    """
    payloads = rng.integers(0, 256, size=(n, EPL_SIZE), dtype=np.uint8)
    src_nodes = (np.arange(n, dtype=np.int64) % powerlink.MAX_CN_NODE_ID) + 1  # CNs 1..239
    inputs: list[EplInput] = [
        (int(s), p.tobytes()) for s, p in zip(src_nodes, payloads, strict=True)
    ]

    def batch_build() -> npt.NDArray[np.uint8]:
        return powerlink.pack_pres_frames(payloads, src_nodes, EPL_NMT, EPL_FLAGS1)

    batch = batch_build()
    frames = [row.tobytes() for row in batch]

    def batch_parse() -> Any:
        return powerlink.unpack_pres_frames(batch)

    w = Workload(
        name="epl",
        title=(
            f"EPL PRes: Ethernet + 10-byte PRes header + {EPL_SIZE}-byte payload "
            f"= {EPL_FRAME_BYTES}-byte frame"
        ),
        frame_bytes=EPL_FRAME_BYTES,
        builders={
            "scapy": epl_build_scapy,
            "construct": epl_build_construct,
            "model": epl_build_model,
            "struct": epl_build_struct,
        },
        parsers={
            "scapy": Ether,
            "construct": EPL_CONSTRUCT.parse,
            "model": decode_frame,
            "struct": epl_parse_struct,
        },
        build_labels={
            "scapy": "Ether()/EplPRes() (minimal layer defined here); bytes()",
            "construct": "Struct(header_schema, pres_schema).build",
            "model": "powerlink.frame(PRes(src, payload)).to_bytes()",
            "struct": "struct Ethernet header + pack_pres(src, payload)",
            "numpy": f"pack_pres_frames, {n:,} frames per call",
        },
        parse_labels={
            "scapy": "Ether(frame)",
            "construct": "Struct(header_schema, pres_schema).parse",
            "model": "decode_frame(frame)",
            "struct": "struct Ethernet header + powerlink.decode(frame[14:])",
            "numpy": "unpack_pres_frames on one (n, 216) uint8 array",
        },
        inputs=inputs,
        frames=frames,
        batch_build=batch_build,
        batch_parse=batch_parse,
        struct_decoder="powerlink.decode(frame[14:])",
    )
    if len(frames[0]) != EPL_FRAME_BYTES:
        raise Mismatch(f"EPL frame is {len(frames[0])} bytes, expected {EPL_FRAME_BYTES}")
    for family, sample in (
        ("scapy", _sample(n, 500)),
        ("construct", _sample(n, 2000)),
        ("model", _sample(n, checked)),
        ("struct", _sample(n, checked)),
    ):
        _check_encoder(w, family, sample)
    for family, sample, fields_of in (
        ("scapy", _sample(n, 500), epl_fields_scapy),
        ("construct", _sample(n, 2000), epl_fields_construct),
        ("model", _sample(n, min(20000, checked)), epl_fields_model),
    ):
        _check_decoder(w, family, sample, fields_of, epl_fields_expected)
    for i in _sample(n, min(20000, checked)):
        message, used, findings = epl_parse_struct(frames[i])
        dst, src, ethertype = _ETH_HEAD.unpack_from(frames[i])
        got = _epl_fields(dst, src, ethertype, message)
        if findings or used != powerlink.PDO_HEADER_BYTES + EPL_SIZE:
            raise Mismatch(f"powerlink.decode frame {i}: used {used}, findings {findings}")
        if got != epl_fields_expected(inputs[i]):
            raise Mismatch(f"EPL struct decoder, frame {i}: {got!r:.200}")
    nodes, got_payloads = batch_parse()
    if not (np.array_equal(nodes, src_nodes) and np.array_equal(got_payloads, payloads)):
        raise Mismatch("EPL numpy batch decoder disagrees with the inputs")
    return w


# --- verification helpers -------------------------------------------------------------------------
def _sample(n: int, count: int) -> list[int]:
    """``count`` frame indices spread over the corpus, always with the first and the last."""
    if count >= n:
        return list(range(n))
    step = (n - 1) / (count - 1)
    return sorted({round(i * step) for i in range(count)})


def _check_encoder(w: Workload, family: str, sample: Iterable[int]) -> None:
    build = w.builders[family]
    for i in sample:
        got = build(w.inputs[i])
        if got != w.frames[i]:
            at = next(
                (k for k, (a, b) in enumerate(zip(got, w.frames[i], strict=False)) if a != b),
                min(len(got), len(w.frames[i])),
            )
            raise Mismatch(
                f"{w.name} {family} encoder, frame {i}: {len(got)} bytes vs the batch's "
                f"{len(w.frames[i])}, first difference at byte {at}"
            )


def _check_decoder(
    w: Workload,
    family: str,
    sample: Iterable[int],
    fields_of: Callable[[Any], Any],
    expected: Callable[[Any], Any],
) -> None:
    parse = w.parsers[family]
    for i in sample:
        got = fields_of(parse(w.frames[i]))
        want = expected(w.inputs[i])
        if got != want:
            raise Mismatch(
                f"{w.name} {family} decoder, frame {i}:\n  got  {got!r:.300}\n  want {want!r:.300}"
            )


# --- timing --------------------------------------------------------------------------------------
def _timed(run: Callable[[], object]) -> float:
    """Seconds for one call of ``run``, gc collected before and disabled inside (as timeit)."""
    gc.collect()
    enabled = gc.isenabled()
    gc.disable()
    try:
        start = time.perf_counter()
        run()
        return time.perf_counter() - start
    finally:
        if enabled:
            gc.enable()


def _per_frame_run(fn: Callable[[Any], object], items: Sequence[Any], n: int) -> Callable[[], None]:
    def run() -> None:
        for item in itertools.islice(items, n):
            fn(item)

    return run


@dataclass(frozen=True)
class Job:
    """One timed variant: build or parse, of one family, of one workload."""

    workload: Workload
    kind: str  # "build" | "parse"
    family: str

    def prepare(self, seconds: float) -> tuple[Callable[[], object], int]:
        """The callable to time and how many frames one call processes."""
        w = self.workload
        n_all = len(w.frames)
        if self.family == "numpy":
            return (w.batch_build if self.kind == "build" else w.batch_parse), n_all
        fn = w.builders[self.family] if self.kind == "build" else w.parsers[self.family]
        items: Sequence[Any] = w.inputs if self.kind == "build" else w.frames
        key = (self.kind, self.family)
        if key not in w.timed_frames:  # calibrate once: a prefix that takes about `seconds`
            n, elapsed = 8, 0.0
            while elapsed < 0.05 * seconds + 0.01 and n < n_all:
                n = min(n * 4, n_all)
                elapsed = _timed(_per_frame_run(fn, items, n))
            w.timed_frames[key] = max(8, min(n_all, round(n * seconds / elapsed)))
        n = w.timed_frames[key]
        return _per_frame_run(fn, items, n), n


def run_rounds(jobs: list[Job], rounds: int, seconds: float) -> None:
    """Run every job once per round, rotating the order; record frames/s."""
    for job in jobs:  # calibration and a warm-up, outside the timed rounds
        job.prepare(seconds)
    for r in range(rounds):
        shift = r % len(jobs)
        order = jobs[shift:] + jobs[:shift]
        started = time.perf_counter()
        for job in order:
            run, n = job.prepare(seconds)
            fps = n / _timed(run)
            job.workload.fps.setdefault((job.kind, job.family), []).append(fps)
        print(
            f"  round {r + 1}/{rounds} done ({time.perf_counter() - started:.1f} s)",
            file=sys.stderr,
            flush=True,
        )


# --- report --------------------------------------------------------------------------------------
def _ratio(w: Workload, kind: str, family: str, base: str) -> float:
    """Median over the rounds of fps(family) / fps(base), paired within each round."""
    mine, theirs = w.fps[(kind, family)], w.fps[(kind, base)]
    return statistics.median(a / b for a, b in zip(mine, theirs, strict=True))


def _fmt_fps(value: float) -> str:
    return f"{value:,.0f}"


def _fmt_ratio(value: float) -> str:
    if value >= 100:
        return f"{value:,.0f}×"
    if value >= 10:
        return f"{value:.1f}×"
    return f"{value:.2f}×"


def report(w: Workload, rounds: int) -> list[str]:
    """Print the workload's table; return the target lines."""
    wire = w.frame_bytes + WIRE_EXTRA_BYTES
    print(f"\n### {w.title}")
    print(
        f"Wire: {w.frame_bytes} + {WIRE_EXTRA_BYTES} = {wire} B = "
        f"{wire * 8 / LINK_BITS_PER_S * 1e6:.1f} µs -> {w.wire_fps:,.0f} frames/s at 100 Mbit/s "
        f"(×RT = fps / {w.wire_fps:,.0f}). Median of {rounds} rounds.\n"
    )
    header = (
        "| variant | build fps | parse fps | build ×scapy | parse ×scapy "
        "| build ×construct | parse ×construct | build ×RT | parse ×RT | frames/run b/p |"
    )
    print(header)
    print("|---|" + "---:|" * 9)
    for family in FAMILIES:
        cells = [FAMILY_LABELS[family]]
        build = statistics.median(w.fps[("build", family)])
        parse = statistics.median(w.fps[("parse", family)])
        cells += [_fmt_fps(build), _fmt_fps(parse)]
        for base in ("scapy", "construct"):
            cells += [_fmt_ratio(_ratio(w, kind, family, base)) for kind in ("build", "parse")]
        cells += [f"{build / w.wire_fps:,.2f}", f"{parse / w.wire_fps:,.2f}"]
        if family == "numpy":
            cells.append(f"{len(w.frames):,} (batch)")
        else:
            cells.append(
                f"{w.timed_frames[('build', family)]:,} / {w.timed_frames[('parse', family)]:,}"
            )
        print("| " + " | ".join(cells) + " |")
    print()
    for family in FAMILIES:
        print(
            f"- {FAMILY_LABELS[family]}: build `{w.build_labels[family]}`; "
            f"parse `{w.parse_labels[family]}`"
        )
    proto = "EtherCAT" if w.name == "ecat" else "EPL PRes"
    lines = []
    for kind in ("build", "parse"):
        lines.append(_target(proto, f"batch {kind} (numpy)", _ratio(w, kind, "numpy", "scapy")))
    for family, what in (("model", "decode_frame(frame)"), ("struct", w.struct_decoder)):
        ratio = _ratio(w, "parse", family, "scapy")
        lines.append(_target(proto, f"per-frame decode, {what}", ratio, TARGET_PER_FRAME_DECODE))
    return lines


def _target(proto: str, what: str, ratio: float, target: float = TARGET_BATCH) -> str:
    verdict = "MET" if ratio >= target else "NOT MET"
    return f"| {proto} | {what} | ≥ {target:,.0f}× | {_fmt_ratio(ratio)} | **{verdict}** |"


def _machine() -> str:
    """CPU model and count, and the load average: the context every figure needs."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            names = [line.split(":", 1)[1].strip() for line in f if line.startswith("model name")]
        model = names[0] if names else model
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} logical CPUs, load average {_load()}"


def _load() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "unknown"


def main(argv: Sequence[str] | None = None) -> int:
    """Verify, time, print."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--quick", action="store_true", help="3 rounds of ~0.2 s per variant (a smoke run)"
    )
    parser.add_argument("--rounds", type=int, help="rounds (default 7, or 3 with --quick)")
    parser.add_argument("--seconds", type=float, help="seconds per per-frame variant and round")
    parser.add_argument("--frames", type=int, default=CORPUS_FRAMES, help="corpus size")
    args = parser.parse_args(argv)
    rounds = args.rounds or (3 if args.quick else 7)
    seconds = args.seconds or (0.2 if args.quick else 1.0)
    rng = np.random.default_rng(20240601)

    print(
        f"# skinframes codec benchmark: {platform.python_implementation()} "
        f"{platform.python_version()}, scapy {scapy.__version__}, construct {cs.__version__}, "
        f"numpy {np.__version__}; {_machine()}"
    )
    print(
        f"# {args.frames:,} frames per protocol, {rounds} rounds, per-frame prefix ~{seconds} s, "
        f"{time.strftime('%Y-%m-%d %H:%M')}"
    )
    started = time.perf_counter()
    print("building and verifying the corpora ...", file=sys.stderr, flush=True)
    checked = 5000 if args.quick else args.frames
    workloads = [
        ecat_workload(args.frames, rng, checked),
        epl_workload(args.frames, rng, checked),
    ]
    print(
        "# verified before timing: every encoder byte-identical, every decoder the same fields "
        f"({'spread samples' if args.quick else 'whole corpus for the fast paths'}; "
        f"{time.perf_counter() - started:.0f} s)"
    )
    targets: list[str] = []
    for w in workloads:
        print(f"timing {w.name} ...", file=sys.stderr, flush=True)
        jobs = [Job(w, kind, family) for family in FAMILIES for kind in ("build", "parse")]
        run_rounds(jobs, rounds, seconds)
        targets += report(w, rounds)
    print("\n### Targets (ratio to scapy, median of per-round ratios)\n")
    print("| protocol | path | target | measured | verdict |")
    print("|---|---|---:|---:|---|")
    for line in targets:
        print(line)
    print(f"\n# total {time.perf_counter() - started:.0f} s; load average at the end {_load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
