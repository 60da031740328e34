"""A closed ring's pcapng has one interface per master port, every frame on its port (tshark
reads the interfaces), and per interface no sender's frames overlap on the wire."""

from __future__ import annotations

from pathlib import Path

import pytest
import tshark_util

from emulator import PAPER, simulate_ecat
from skinframes import ethercat, read_capture
from skinframes.check import check_capture

pytestmark = pytest.mark.tshark

PORT_MAC = {0: ethercat.MASTER_MAC, 1: ethercat.MASTER_MAC_SECOND}


def test_closed_ring_pcapng_has_one_interface_per_port(tshark: str, tmp_path: Path) -> None:
    path = tmp_path / "ring.pcapng"
    simulate_ecat(5, 192, PAPER, closed_ring=True, cycles=3, pcap=str(path))
    names = [
        "frame.interface_id",
        "frame.interface_name",
        "eth.src",
        "frame.packet_flags_direction",
    ]
    rows = tshark_util.fields(tshark, path, names)
    interfaces = {(r["frame.interface_id"][0], r["frame.interface_name"][0]) for r in rows}
    assert interfaces == {("0", "master port 0"), ("1", "master port 1")}
    for r in rows:
        port = int(r["frame.interface_id"][0])
        src = bytes.fromhex(r["eth.src"][0].replace(":", ""))
        if int(r["frame.packet_flags_direction"][0], 0) & 3 == 2:  # outbound: sent by this port
            assert src == PORT_MAC[port]
        else:  # inbound: the frame the other port sent, after the ring
            assert src in (PORT_MAC[1 - port], ethercat.returned_mac(PORT_MAC[1 - port]))
    assert {r.interface for r in read_capture(path)} == {0, 1}
    report = check_capture(read_capture(path))
    assert report.errors == report.warnings == 0
