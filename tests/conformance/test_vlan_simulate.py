"""``simulate --vlan ID``: every frame 802.1Q-tagged, built by skinframes, clean in tshark, and the
4 bytes per tag counted on the wire."""

from __future__ import annotations

from pathlib import Path

import pytest
import tshark_util

from conformance.test_tshark import assert_fields_agree
from emulator import PAPER, simulate_ecat, simulate_epl
from skinframes import decode_frame, read_capture
from skinframes.check import check_capture
from skinframes.vlan import VlanTag

pytestmark = pytest.mark.tshark

SIMULATE = {"epl": simulate_epl, "ecat": simulate_ecat}
STACK = {
    "epl": "eth:ethertype:vlan:ethertype:epl",
    "ecat": "eth:ethertype:vlan:ethertype:ecatf:ecat",
}
# bytes a tag adds to a cycle, by hand: EPL 4 PRes of 14 + 10 + 192 bytes grow by 4 (SoC, PReq
# and SoA stay within the 60-byte minimum); EtherCAT: the one frame of 4 LRDs, counted once
GROWTH_BYTES = {"epl": 4 * 4, "ecat": 4}


@pytest.mark.parametrize("protocol", ["epl", "ecat"])
def test_vlan_frames_are_clean_and_timed(protocol: str, tshark: str, tmp_path: Path) -> None:
    run = SIMULATE[protocol]
    plain_path, tagged_path = tmp_path / "plain.pcap", tmp_path / "tagged.pcap"
    plain = run(4, 192, PAPER, cycles=5, pcap=plain_path)
    tagged = run(4, 192, PAPER, cycles=5, pcap=tagged_path, vlan=42)
    run(4, 192, PAPER, cycles=5, pcap=tmp_path / "walked.pcap", vlan=42, fast=False)  # walked
    assert (tmp_path / "walked.pcap").read_bytes() == tagged_path.read_bytes()
    growth_ps = GROWTH_BYTES[protocol] * PAPER.byte_ps
    assert tagged.details[0].cycle_ps - plain.details[0].cycle_ps == growth_ps
    assert tshark_util.problems(tshark, tagged_path) == []
    stacks = set(
        tshark_util.run(tshark, tagged_path, "-T", "fields", "-e", "frame.protocols").split()
    )
    assert stacks <= {STACK[protocol], STACK[protocol] + ":data"}, stacks
    assert assert_fields_agree(tshark, tagged_path) == len(read_capture(tagged_path))
    for a, b in zip(read_capture(plain_path), read_capture(tagged_path), strict=True):
        fa, fb = decode_frame(a.data), decode_frame(b.data)
        assert fb.tags == (VlanTag(42),)
        assert (fb.dst, fb.src, type(fb.payload)) == (fa.dst, fa.src, type(fa.payload))
        if type(fa.payload).__name__ != "SoC":  # a SoC carries its (now later) time
            assert fb.payload == fa.payload
        assert fb.to_bytes() == b.data
    report = check_capture(read_capture(tagged_path))
    assert report.errors == report.warnings == 0
