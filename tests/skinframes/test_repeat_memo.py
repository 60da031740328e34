"""Frames that repeat are decoded once: the results equal decoding every frame anew."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from emulator import PAPER, simulate_ecat, simulate_epl
from skinframes import check
from skinframes.describe import JsonDescriber, describe_record, record_json
from skinframes.dispatch import RepeatMemo
from skinframes.pcap import read_capture

ROOT = Path(__file__).resolve().parent.parent.parent


@pytest.fixture(scope="module")
def captures(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    d = tmp_path_factory.mktemp("memo")
    simulate_epl(5, 192, PAPER, cycles=6, asnd=True, pcap=d / "epl.pcap")
    simulate_ecat(9, 64, PAPER, closed_ring=True, cycles=6, pcap=d / "ring.pcapng")
    return [d / "epl.pcap", d / "ring.pcapng", *sorted((ROOT / "pcaps").glob("*.pcap"))]


def test_json_objects_equal_those_computed_frame_by_frame(captures: list[Path]) -> None:
    for path in captures:
        describe = JsonDescriber()
        for rec in read_capture(path):
            assert describe(rec) == record_json(rec) == describe_record(rec)[0]


def test_check_reports_equal_those_of_decoding_every_frame(
    captures: list[Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    memo = [check.check_capture(read_capture(p)).to_json() for p in captures]
    monkeypatch.setattr(check, "RepeatMemo", lambda compute, **_: compute)
    assert memo == [check.check_capture(read_capture(p)).to_json() for p in captures]


def test_the_memory_is_bounded_and_errors_are_not_remembered() -> None:
    calls: list[int] = []

    def square(x: int) -> int:
        calls.append(x)
        if x < 0:
            raise ValueError(x)
        return x * x

    memo: RepeatMemo[int, int] = RepeatMemo(square, entries=3)
    assert [memo(x) for x in (1, 2, 1, 2, 3)] == [1, 4, 1, 4, 9] and calls == [1, 2, 3]
    assert memo(4) == 16 and len(memo._memo) <= 3
    for _ in range(2):
        with pytest.raises(ValueError):
            memo(-1)
    assert calls.count(-1) == 2


@given(
    st.sampled_from([3, 4, 0x84, 5]),
    st.binary(min_size=12, max_size=12),
    st.binary(min_size=7, max_size=7),
    st.binary(max_size=300),
    st.binary(max_size=300),
    st.binary(max_size=6),
)
def test_a_pdo_payload_changes_no_finding(
    mtype: int, macs: bytes, head: bytes, payload: bytes, other: bytes, padding: bytes
) -> None:
    """Frames with equal judged_bytes get equal findings (decoder's and node ids')."""
    other = (other + bytes(len(payload)))[: len(payload)]
    size = len(payload).to_bytes(2, "little")
    a = macs + b"\x88\xab" + bytes([mtype]) + head + size + payload + padding
    b = macs + b"\x88\xab" + bytes([mtype]) + head + size + other + padding
    if check.judged_bytes(a) != check.judged_bytes(b):
        assert len(padding) >= 4 or mtype not in (3, 4)
        return
    for_a, for_b = check._decode(a), check._decode(b)
    assert for_a[1:] == for_b[1:]
    pa, pb = for_a[0].payload, for_b[0].payload
    assert (type(pa), pa.src, pa.dest) == (type(pb), pb.src, pb.dest)  # type: ignore[union-attr]


@given(
    st.lists(
        st.tuples(
            st.sampled_from([0x0A, 0x0B, 0x0C, 0x04]),
            st.binary(min_size=0, max_size=120),
            st.integers(0, 0xFFFF),
        ),
        min_size=1,
        max_size=6,
    ),
    st.binary(min_size=1, max_size=1),
    st.binary(max_size=6),
    st.booleans(),
)
def test_ecat_process_data_changes_no_finding(
    datagrams: list[tuple[int, bytes, int]], flip: bytes, padding: bytes, bad_length: bool
) -> None:
    """Frames with equal judged_bytes get equal findings, whatever the datagrams' data."""
    from skinframes import ethercat

    def body(flipped: bool) -> bytes:
        dgs = tuple(
            ethercat.Datagram(cmd, 0, 0, bytes(b ^ flip[0] for b in data) if flipped else data)
            for cmd, data, _ in datagrams
        )
        frame = ethercat.EcatFrame(dgs, length=5 if bad_length else None)
        return ethercat.frame(frame).to_bytes() + padding

    a, b = body(False), body(True)
    if check.judged_bytes(a) != check.judged_bytes(b):
        message = 16 + sum(12 + len(data) for _, data, _ in datagrams)
        after = len(a) - message  # Ethernet padding to 60 bytes included
        assert after >= 4 or any(cmd == 0x04 for cmd, _, _ in datagrams)
        return
    assert check._decode(a)[1:] == check._decode(b)[1:]
