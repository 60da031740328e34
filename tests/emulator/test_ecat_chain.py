"""The frame-processing chain: its cached per-ESC effects (the timing engine's view) against
processing the frame for real, and the independent mini master's scan run against it in process."""

from __future__ import annotations

import mini_master
import numpy as np
import numpy.typing as npt
import pytest

from emulator.errors import TopologyError
from emulator.esc.chain import EcatChain, configure_frames
from emulator.net.ecat import frames_for
from emulator.slave.sii import SlaveInfo
from skinframes import ethercat, taxel
from skinframes.ethercat import Command as C  # noqa: N817
from skinframes.ethercat import Datagram

N, B = 10, 96


# Register and logical access of every kind, on and off slave boundaries.
DATAGRAMS = [
    Datagram(C.APRD, (-2) & 0xFFFF, 0x0130, bytes(2)),
    Datagram(C.APRD, (-9) & 0xFFFF, 0x0010, bytes(2)),
    Datagram(C.APRD, (-10) & 0xFFFF, 0x0010, bytes(2)),  # behind the last slave
    Datagram(C.APWR, 0, 0x0400, bytes(2)),
    Datagram(C.FPRD, 0x1003, 0x0130, bytes(2)),
    Datagram(C.FPRD, 0x1003, 0x0010, bytes(2)),
    Datagram(C.FPRD, 0x2000, 0x0130, bytes(2)),
    Datagram(C.FPWR, 0x1005, 0x0400, b"\x01\x02"),
    Datagram(C.BRD, 0, 0x0130, bytes(2)),
    Datagram(C.BRD, 7, 0x0000, bytes(1)),
    Datagram(C.BWR, 0, 0x0400, b"\x09\x09"),
    Datagram(C.FRMW, 0x1001, 0x0910, bytes(8)),
    Datagram(C.FRMW, 0x3000, 0x0910, bytes(8)),  # nobody addressed: every slave writes
    Datagram(C.ARMW, (-4) & 0xFFFF, 0x0910, bytes(8)),
    Datagram(C.ARMW, 0x2000, 0x0910, bytes(8)),
    Datagram.logical(C.LRD, 0, bytes(N * B)),
    Datagram.logical(C.LRD, 96, bytes(288)),  # slaves 1-3
    Datagram.logical(C.LRD, 0, bytes(1486)),  # past the image: the rest stays untouched
    Datagram.logical(C.LRW, 0, bytes(96)),
    Datagram.logical(C.LRW, 192, b"\xff" * 192),
    Datagram.logical(C.LWR, 0, bytes(192)),  # inputs only: nobody writes, WKC 0
    Datagram(C.NOP, 0, 0, bytes(2)),
]


def _returned(chain: EcatChain, f: ethercat.EcatFrame, image: npt.NDArray[np.uint8]) -> bytes:
    """The frame as the timing engine rebuilds it from the cached per-ESC effects."""
    eff = chain.frame_effect(f)
    back, mac = eff.returned(range(len(chain)), image.reshape(-1))
    return ethercat.frame(back, returned=mac).to_bytes()


@pytest.mark.parametrize("d", DATAGRAMS, ids=lambda d: f"{C(d.cmd).name}-{d.adp:x}-{d.ado:x}")
def test_cached_effects_equal_processing_the_frame(d: Datagram) -> None:
    """Two views of one ESC model: what the timing engine rebuilds from the effects it cached
    equals the frame the chain returns when it processes the same frame for real."""
    image = taxel.sample_payloads(N, 1, B, seed=11)[0]
    cached, real = EcatChain.configured(N, B), EcatChain.configured(N, B)
    cached.publish(image)
    real.publish(image)
    f = ethercat.EcatFrame((d,))
    assert _returned(cached, f, image) == real.process_frame(ethercat.frame(f).to_bytes())


def test_the_logical_layout_through_the_chain() -> None:
    # the "logical" layout splits the image at 1486 bytes, inside slave 7's buffer
    # (1486 = 7 x 192 + 142): the SyncManager buffer opened in frame 1 is finished in frame 2
    n, size = 12, 192
    image = taxel.sample_payloads(n, 1, size, seed=12)[0]
    chain = EcatChain.configured(n, size)
    chain.publish(image)
    got = b""
    for f in frames_for(n, size, "logical"):
        eff = chain.frame_effect(f)
        back, _ = eff.returned(range(n), image.reshape(-1))
        assert eff.wkc(range(n)) == len({s.position for s in eff.slaves if any(s.wkc)})
        got += back.datagrams[0].data
    assert got == image.tobytes()


def test_a_read_that_starts_inside_a_buffer_is_denied() -> None:
    """A real ESC's SyncManager denies a read that does not begin at the buffer's start
    address (datasheet I 8): slave 1 is not read, slaves 2 and 3 are."""
    image = taxel.sample_payloads(N, 1, B, seed=13)[0]
    chain = EcatChain.configured(N, B)
    chain.publish(image)
    d = Datagram.logical(C.LRD, 100, bytes(192))  # slave 1 from byte 4, slave 2, slave 3 start
    eff = chain.frame_effect(ethercat.EcatFrame((d,)))
    assert eff.wkc(range(N)) == 2
    assert [s.position for s in eff.slaves if any(s.wkc)] == [2, 3]
    back, _ = eff.returned(range(N), image.reshape(-1))
    assert back.datagrams[0].data[:92] == bytes(92)


def test_effects_report_input_bytes_as_runs() -> None:
    chain = EcatChain.configured(3, 16)
    f = ethercat.EcatFrame((Datagram.logical(C.LRD, 0, bytes(40)),))  # slaves 0, 1, 8 bytes of 2
    eff = chain.frame_effect(f)
    at = ethercat.data_offsets(f)[0]
    assert eff.taxel_runs(range(3)) == [(at, 0, 16), (at + 16, 16, 16), (at + 32, 32, 8)]
    assert all(s.constant == () for s in eff.slaves)
    assert chain.input_bytes == 16


def test_configured_chain_state_and_frames() -> None:
    chain = EcatChain.configured(5, 16, logical_base=0x1000, station_base=0x0100)
    assert [dev.station for dev in chain.devices] == [0x100 + p for p in range(5)]
    assert {dev.al_status for dev in chain.devices} == {0x08}
    frames = configure_frames(SlaveInfo.skin_patch(16), 5)
    assert len(frames) == 5 + 1 + 2 * 5 + 3


def test_publish_checks_its_rows() -> None:
    chain = EcatChain.skin(2, 16)
    with pytest.raises(TopologyError):
        chain.publish(np.zeros((3, 16), dtype=np.uint8))
    with pytest.raises(ValueError):
        chain.publish([bytes(16), bytes(15)])
    with pytest.raises(TopologyError):
        EcatChain.skin(0, 16)


@pytest.mark.parametrize(("nodes", "size"), [(1, 192), (7, 192), (21, 192), (40, 16)])
def test_independent_master_scan_in_process(nodes: int, size: int) -> None:
    chain = EcatChain.skin(nodes, size)
    rows = taxel.sample_payloads(nodes, 1, size, seed=nodes)[0]
    chain.publish(rows)
    r = mini_master.scan(chain.process_frame, nodes)
    assert (r["count"], r["brd_adp"], r["esc_type"]) == (nodes, nodes, 0x11)
    assert r["stations"] == [0x2000 + p for p in range(nodes)]
    assert r["identity"] == [
        (0x534B494E, 0x00010000 + size, 0x00010000, p + 1) for p in range(nodes)
    ]
    or_serials = 0
    for p in range(nodes):
        or_serials |= p + 1
    assert (r["broadcast_serial_or"], r["broadcast_wkc"]) == (or_serials, nodes)
    assert r["name"] == f"SkinPatch{size}"
    assert r["input_bytes"] == size
    assert r["sm"] == [0x1000, size, 0x20, 1, 4]  # ETG.2010 SYNCM: type 4 = process data inputs
    assert (r["al_status_4"], r["al_status_8"], r["al_status_final"]) == ("0400", "0800", "0100")
    per = 1486 // size
    assert r["lrd_wkc"] == [min(per, nodes - i) for i in range(0, nodes, per)]
    assert bytes.fromhex(r["inputs"]) == rows.tobytes()


def test_every_returned_frame_has_the_request_length() -> None:
    chain = EcatChain.skin(2, 16)
    for f in frames_for(2, 16, "per-slave") + frames_for(2, 16, "logical"):
        raw = ethercat.frame(f).to_bytes()
        back = chain.process_frame(raw)
        assert back is not None and len(back) == len(raw)


def _sent(chain: EcatChain, d: Datagram) -> Datagram:
    """``d`` in a frame of its own through ``chain``, as it comes back."""
    back = chain.process_frame(ethercat.frame(ethercat.EcatFrame((d,))).to_bytes())
    assert back is not None
    return ethercat.decode(back[14:])[0].datagrams[0]


def test_each_esc_keeps_its_fmmu_span_in_the_chains_row() -> None:
    """Hand-worked: ``EcatChain.configured`` maps slave p's 8 input bytes at logical 8 p
    (FMMU 0, byte-wise), so its span is [8 p, 8 p + 8). A BWR of FMMU 0's logical start
    (0x0600, 4 bytes) moves every span to [0x100, 0x108): an LRD of the image then reaches no
    ESC and one at 0x100 every ESC. Disabling FMMU 0 of slave 1 (station 0x1002, 0x060C = 0)
    leaves it no span, (0, 0), and takes it out of the working counter."""
    chain = EcatChain.configured(3, 8)
    assert chain.fmmu_spans.tolist() == [[0, 8], [8, 16], [16, 24]]
    assert [dev.fmmu_span for dev in chain.devices] == [(0, 8), (8, 16), (16, 24)]
    assert _sent(chain, Datagram.logical(C.LRD, 0, bytes(24))).wkc == 3
    _sent(chain, Datagram(C.BWR, 0, 0x0600, (0x100).to_bytes(4, "little")))
    assert chain.fmmu_spans.tolist() == [[0x100, 0x108]] * 3
    assert _sent(chain, Datagram.logical(C.LRD, 0, bytes(24))).wkc == 0
    assert _sent(chain, Datagram.logical(C.LRD, 0x100, bytes(8))).wkc == 3
    _sent(chain, Datagram(C.FPWR, 0x1002, 0x060C, b"\x00"))
    assert chain.fmmu_spans.tolist() == [[0x100, 0x108], [0, 0], [0x100, 0x108]]
    assert chain.devices[1].fmmu_span == (0, 0)
    assert _sent(chain, Datagram.logical(C.LRD, 0x100, bytes(8))).wkc == 2


def test_frames_of_one_length_and_header_with_other_datagrams_are_read_as_they_are() -> None:
    # an LRD of 20 bytes and two APRDs of 4 make EtherCAT frames of one length (header length
    # 32, 60 bytes padded): each is read by its own datagram headers (ETG.1000.4 Table 12), in
    # any order, however the chain found the one before
    chain = EcatChain.configured(2, 8)
    chain.publish([bytes(range(8)), bytes(range(8, 16))])
    image = ethercat.frame(ethercat.EcatFrame((Datagram.logical(C.LRD, 0, bytes(20)),)))
    stations = ethercat.frame(
        ethercat.EcatFrame(
            (Datagram(C.APRD, 0, 0x0010, bytes(4)), Datagram(C.APRD, 0xFFFF, 0x0010, bytes(4)))
        )
    )
    assert len(image.to_bytes()) == len(stations.to_bytes())
    for ask in (image, stations, image, stations, stations, image):
        back = chain.process_frame(ask.to_bytes())
        assert back is not None
        got = ethercat.decode(back[14:])[0].datagrams
        if ask is image:
            assert [(d.data, d.wkc) for d in got] == [(bytes(range(16)) + bytes(4), 2)]
        else:  # station address 0x0010 (0x1001, 0x1002), alias 0x0012 zero
            assert [(d.data, d.wkc) for d in got] == [
                (b"\x01\x10\x00\x00", 1),
                (b"\x02\x10\x00\x00", 1),
            ]


def test_a_frame_not_ethercat_is_lost_where_a_port_is_open_without_a_link() -> None:
    """Datasheet II 2.4.1 (DL control 0x0100): with bit 0 = 0 an ESC forwards frames that are
    not EtherCAT; bits 10-11 = 10 force port 1 open, and the last ESC has no link there, so
    every frame, EtherCAT or not, goes out into nothing. The IPv4 frame came back unchanged
    from such a line until the chain asked how far frames go (it was lost for EtherCAT ones)."""
    from emulator.esc.chain import STATION_BASE

    def frame(*datagrams: Datagram) -> bytes:
        return ethercat.frame(ethercat.EcatFrame(datagrams)).to_bytes()

    chain = EcatChain.configured(3, 8)
    ipv4 = b"\xff" * 6 + b"\x02\x00\x00\x00\x00\x01" + b"\x08\x00" + bytes(46)
    assert chain.process_frame(frame(Datagram(C.BWR, 0, 0x0100, b"\x00"))) is not None
    assert chain.process_frame(ipv4) == ipv4  # forwarded, back from the last ESC's closed port
    assert chain.dropped == 0
    open_port1 = Datagram(C.FPWR, STATION_BASE + 2, 0x0100, b"\x00\x08")
    assert chain.process_frame(frame(open_port1)) is not None  # (lost from the next frame on)
    assert chain.process_frame(ipv4) is None
    assert chain.process_frame(frame(Datagram(C.BRD, 0, 0x0000, b"\x00"))) is None
    assert chain.dropped == 2
