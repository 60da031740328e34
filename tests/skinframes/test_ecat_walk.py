"""The vectorised EtherCAT datagram walk (capture_taxels.ecat_datagrams) equals the construct
schema of record and the per-frame decoder, on random valid frames and on every EtherCAT frame
of the real captures and pcaps/."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from skinframes import ethercat, ethernet
from skinframes.capture_taxels import ecat_datagrams
from skinframes.pcap import read_capture

ROOT = Path(__file__).resolve().parent.parent.parent


def walk(frames: list[bytes]) -> list[list[tuple[int, int, int, bytes, int]]]:
    """(cmd, idx, lad, data, wkc) of each datagram of each frame (EtherCAT bytes), vectorised."""
    data = np.frombuffer(b"".join(frames), dtype=np.uint8)
    lengths = np.array([len(f) for f in frames], dtype=np.int64)
    at = np.cumsum(lengths) - lengths
    cols = ecat_datagrams(data, at, at + lengths)
    out: list[list[tuple[int, int, int, bytes, int]]] = [[] for _ in frames]
    for i in range(cols["frame"].shape[0]):
        start, n = int(cols["data_at"][i]), int(cols["length"][i])
        out[int(cols["frame"][i])].append(
            (
                int(cols["cmd"][i]),
                int(cols["idx"][i]),
                int(cols["lad"][i]),
                data[start : start + n].tobytes(),
                int(cols["wkc"][i]),
            )
        )
    return out


def by_schema(body: bytes) -> list[tuple[int, int, int, bytes, int]]:
    parsed = ethercat.frame_schema.parse(body)
    return [(d.cmd, d.idx, d.adp | d.ado << 16, bytes(d.data), d.wkc) for d in parsed.datagrams]


def by_decoder(body: bytes) -> list[tuple[int, int, int, bytes, int]]:
    frame, _, _ = ethercat.decode(body, strict=False)
    return [(int(d.cmd), d.idx, d.lad, d.data, d.wkc) for d in frame.datagrams]


datagram = st.builds(
    ethercat.Datagram,
    cmd=st.sampled_from(list(ethercat.Command)[:-1]),
    adp=st.integers(0, 0xFFFF),
    ado=st.integers(0, 0xFFFF),
    data=st.binary(max_size=200),
    idx=st.integers(0, 0xFF),
    irq=st.integers(0, 0xFFFF),
    wkc=st.integers(0, 0xFFFF),
    circulating=st.booleans(),
)


@given(st.lists(st.lists(datagram, min_size=1, max_size=7), min_size=1, max_size=5))
def test_random_frames_walk_as_the_schema_parses(frames: list[list[ethercat.Datagram]]) -> None:
    bodies = [ethercat.EcatFrame(tuple(dgs)).to_bytes() for dgs in frames]
    assert walk(bodies) == [by_schema(b) for b in bodies]


def ecat_bodies(paths: list[Path]) -> list[bytes]:
    out = []
    for path in paths:
        for rec in read_capture(path):
            if len(rec.data) > 16 and rec.data[12:14] == b"\x88\xa4":
                out.append(rec.data[ethernet.HEADER_BYTES :])
    return out


def test_every_ecat_frame_of_the_pcaps_and_real_captures(shared_captures: Path) -> None:
    paths = sorted((ROOT / "pcaps").glob("ecat_*.pcap")) + sorted(
        shared_captures.glob("ethercrab*")
    )
    bodies = ecat_bodies(paths)
    assert len(bodies) > 1000
    assert walk(bodies) == [by_decoder(b) for b in bodies]
