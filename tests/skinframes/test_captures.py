"""Every frame of every third-party capture is read, decoded and re-encoded byte for byte."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
import tshark_util

from skinframes import decode_frame, protocol_of, read_capture
from skinframes.pcap import LINKTYPE_ETHERNET

CAPTURES = [
    "epl-viz_EPL_Example.cap",
    "epl-viz_1CN.pcapng",
    "epl-viz_MultiWriteRead_example.pcapng",
    "ethercrab_replay-ek1100-el2828-el2889.pcapng",
    "ethercrab_soem-sdinfo-ek1100-el1004.pcapng",
]


def _decode_all(path: Path) -> tuple[Counter[str], Counter[str], int]:
    capture = read_capture(path)
    protocols: Counter[str] = Counter()
    findings: Counter[str] = Counter()
    for rec in capture:
        assert rec.linktype == LINKTYPE_ETHERNET
        frame = decode_frame(rec.data)
        assert frame.to_bytes() == rec.data, f"record {rec.index} does not round-trip"
        protocols[protocol_of(frame)] += 1
        findings.update(f.code for f in frame.findings)
    assert capture.skipped == ()
    return protocols, findings, capture.total


@pytest.mark.parametrize("name", CAPTURES)
def test_capture_round_trips(shared_captures: Path, name: str) -> None:
    protocols, _, total = _decode_all(shared_captures / name)
    assert sum(protocols.values()) == total > 0


def test_the_whole_folder_is_covered(shared_captures: Path) -> None:
    files = {p.name for p in shared_captures.iterdir() if p.is_file() and p.suffix != ".md"}
    assert files == set(CAPTURES), "a capture was added to ../shared/captures: list it here"


@pytest.mark.tshark
@pytest.mark.parametrize("name", CAPTURES)
def test_counts_equal_tsharks(tshark: str, shared_captures: Path, name: str) -> None:
    path = shared_captures / name
    protocols, _, total = _decode_all(path)
    rows = tshark_util.fields(tshark, path, ["eth.type"])
    assert len(rows) == total
    types = Counter(int(r["eth.type"][0], 0) if r["eth.type"] else None for r in rows)
    assert protocols["epl"] == types[0x88AB]
    assert protocols["ecat"] == types[0x88A4]
    assert protocols["other"] == total - types[0x88AB] - types[0x88A4]


def test_known_deviations_become_findings(shared_captures: Path) -> None:
    # counts from tshark -z io,phs and frame sizes (frames.md 5): unpadded TX frames, SOEM's group
    # source MAC, a capture that kept the FCS
    _, f, _ = _decode_all(shared_captures / "ethercrab_soem-sdinfo-ek1100-el1004.pcapng")
    assert f["eth.src.group"] == 580
    _, f, _ = _decode_all(shared_captures / "ethercrab_replay-ek1100-el2828-el2889.pcapng")
    assert f["eth.unpadded"] == 1789
    _, f, _ = _decode_all(shared_captures / "epl-viz_MultiWriteRead_example.pcapng")
    assert f["eth.fcs"] == 7


def test_wiresharks_malformed_sdo_frames_are_complete_segments(shared_captures: Path) -> None:
    """tshark flags 2 frames Malformed (frames.md 5); their SDO segments are whole (hand-read):
    record 1: WriteMultipleParam response, one 8-byte entry (0x6101/5, abort 0x06070010);
    record 5: ReadMultipleParam request, five 4-byte entries (0x6101/1..4, 0x6101/0xee)."""
    from skinframes.powerlink import ASnd, Sdo

    recs = list(read_capture(shared_captures / "epl-viz_MultiWriteRead_example.pcapng"))
    want = {
        1: bytes.fromhex("0161058010000706"),
        5: bytes.fromhex("016101000161020001610300016104000161ee00"),
    }
    for index, data in want.items():
        frame = decode_frame(recs[index].data)
        assert isinstance(frame.payload, ASnd) and isinstance(frame.payload.service, Sdo)
        command = frame.payload.service.command
        assert command is not None and command.data == data
        assert "epl.sdo.multi_param.padding" in {f.code for f in frame.findings}
