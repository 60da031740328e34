"""Wireshark is the judge: tshark must dissect what we write cleanly and agree with our decoder."""

from __future__ import annotations

from pathlib import Path

import pytest
import tshark_util

from conformance.fields import ALL_FIELDS, Extract
from skinframes import decode_frame, ethercat, golden, powerlink, protocol_of, read_capture
from skinframes.pcap import write_pcap

pytestmark = pytest.mark.tshark

PCAPS = Path(__file__).resolve().parents[2] / "pcaps"
STACKS = {"epl": "eth:ethertype:epl", "ecat": "eth:ethertype:ecatf:ecat"}


def assert_fields_agree(
    tshark: str, path: Path, table: dict[str, Extract] = ALL_FIELDS, *options: str
) -> int:
    """tshark's value of every field of ``table`` equals ours, frame by frame (``options``: more
    tshark arguments); returns frames compared."""
    names = list(table)
    rows = tshark_util.fields(tshark, path, names, "", *options)
    records = list(read_capture(path))
    assert len(rows) == len(records)
    for rec, row in zip(records, rows, strict=True):
        frame = decode_frame(rec.data)
        for name, extract in table.items():
            theirs = [int(v, 0) for v in row[name]]
            assert extract(frame) == theirs, (
                f"record {rec.index}: {name} ours {extract(frame)} tshark {theirs}"
            )
    return len(rows)


def assert_protocols_agree(tshark: str, path: Path) -> int:
    """Where tshark names EPL or EtherCAT we decode EPL or EtherCAT, and nowhere else; returns
    the number of such frames."""
    stacks = tshark_util.run(tshark, path, "-T", "fields", "-e", "frame.protocols").split()
    records = list(read_capture(path))
    assert len(stacks) == len(records)
    ours_total = 0
    for rec, stack in zip(records, stacks, strict=True):
        layers = stack.split(":")
        theirs = "epl" if "epl" in layers else "ecat" if "ecatf" in layers else "other"
        ours = protocol_of(decode_frame(rec.data)) if rec.linktype == 1 else "other"
        assert ours == theirs, f"record {rec.index}: ours {ours}, tshark {stack}"
        ours_total += ours != "other"
    return ours_total


@pytest.mark.parametrize("name", sorted(golden.SCENARIOS))
def test_golden_pcap_is_clean_and_agrees(tshark: str, name: str) -> None:
    path = PCAPS / f"{name}.pcap"
    assert tshark_util.problems(tshark, path) == []
    stacks = set(tshark_util.run(tshark, path, "-T", "fields", "-e", "frame.protocols").split())
    want = STACKS[name.split("_")[0]]
    assert stacks <= {want, want + ":data"}, stacks
    assert assert_fields_agree(tshark, path) > 0
    assert assert_protocols_agree(tshark, path) == len(golden.build(name))


@pytest.mark.parametrize(
    "name",
    [
        "epl-viz_EPL_Example.cap",
        "epl-viz_1CN.pcapng",
        "epl-viz_MultiWriteRead_example.pcapng",
        "ethercrab_replay-ek1100-el2828-el2889.pcapng",
        "ethercrab_soem-sdinfo-ek1100-el1004.pcapng",
    ],
)
def test_real_capture_fields_agree(tshark: str, shared_captures: Path, name: str) -> None:
    assert assert_fields_agree(tshark, shared_captures / name) > 0
    assert assert_protocols_agree(tshark, shared_captures / name) > 0


def test_enums_equal_tshark_values(tshark: str) -> None:
    assert tshark_util.values(tshark, "ecat.cmd").keys() == {int(c) for c in ethercat.Command}
    assert tshark_util.values(tshark, "ecatf.type").keys() == {int(t) for t in ethercat.FrameType}
    assert tshark_util.values(tshark, "epl.mtyp").keys() == {int(t) for t in powerlink.MessageType}


def test_frames_of_every_size_are_clean(tshark: str, tmp_path: Path) -> None:
    """PRes of 0..1490 bytes and EtherCAT frames of 1..max datagrams, all at once."""
    records = [
        powerlink.frame(powerlink.PRes(7, (bytes(range(256)) * 6)[:size])).to_bytes()
        for size in (0, 1, 35, 36, 37, 192, 1000, powerlink.MAX_PDO_PAYLOAD_BYTES)
    ]
    for size in (1, 2, 192, 700):
        k = ethercat.datagrams_per_frame(size)
        dgs = [
            ethercat.Datagram.logical(ethercat.Command.LRD, i * size, bytes(size), wkc=1)
            for i in range(k)
        ]
        records.append(ethercat.frame(ethercat.EcatFrame(tuple(dgs))).to_bytes())
    path = tmp_path / "sizes.pcap"
    write_pcap(path, [(i * 1000, r) for i, r in enumerate(records)])
    assert tshark_util.problems(tshark, path) == []
    assert assert_fields_agree(tshark, path) == len(records)
