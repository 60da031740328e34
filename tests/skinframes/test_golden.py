"""The golden pcaps are rebuilt in memory and compared byte for byte (--update-golden rewrites)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from skinframes import decode_frame, golden, read_capture
from skinframes.pcap import pcap_bytes

PCAPS = Path(__file__).resolve().parents[2] / "pcaps"


@pytest.mark.parametrize("name", sorted(golden.SCENARIOS))
def test_golden_rebuilds_byte_for_byte(
    name: str, golden_file: Callable[[str, bytes], None]
) -> None:
    golden_file(f"{name}.pcap", pcap_bytes(golden.build(name)))


@pytest.mark.parametrize("name", sorted(golden.SCENARIOS))
def test_golden_decodes_strictly(name: str) -> None:
    for rec in read_capture(PCAPS / f"{name}.pcap"):
        frame = decode_frame(rec.data, strict=True)
        assert frame.to_bytes() == rec.data
        assert frame.findings == ()


def test_golden_layouts() -> None:
    """What the issue asks each file to hold, counted from the bytes."""

    def frames(name: str) -> list:
        return [decode_frame(r.data).payload for r in read_capture(PCAPS / f"{name}.pcap")]

    epl = frames("epl_cycle_4cn")
    assert [type(m).__name__ for m in epl] == ["SoC"] + ["PReq", "PRes"] * 4 + ["SoA"]
    assert [m.size for m in epl if type(m).__name__ == "PRes"] == [192] * 4
    asnd = [m.service_id for m in frames("epl_asnd_services") if type(m).__name__ == "ASnd"]
    assert sorted(set(asnd)) == [1, 2, 3, 4, 5]
    (_, back) = frames("ecat_lrd_7x192")
    assert [(int(d.cmd), d.length, d.wkc) for d in back.datagrams] == [(0x0A, 192, 1)] * 7
    assert [len(f.datagrams) for f in frames("ecat_23_slaves")] == [
        7,
        7,
        7,
        2,
    ] * 2  # 1498 // 204 = 7
    cmds = [int(f.datagrams[0].cmd) for f in frames("ecat_all_commands")]
    assert cmds == list(range(15))
