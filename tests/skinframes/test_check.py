"""``skinframes.check`` on hand-built captures: each rule once with a clean and a broken case.

Frames are built with the codecs and then damaged by patching bytes at the offsets of the frame
layouts (frames.md sections 1.2 and 2; DS 301 for EPL, ETG.1000.4 for EtherCAT):

- Ethernet: 14-byte header; the payload starts at offset 14.
- EPL: MessageType, Destination, Source at payload offsets 0, 1, 2. PReq/PRes: Size is a u16 LE at
  payload offset 8 (after NMTStatus/reserved, Flags1, Flags2, PDOVersion, reserved).
- EtherCAT: a u16 LE header (length bits 0-10, type bits 12-15), then datagrams of
  cmd, idx, address (4), length|R|C|M (u16 LE, M = bit 15), irq (2), data, wkc (2).

Node-id rules are DS 301 4.2.5.1.1 (CN 1-239, MN 240, broadcast 255); the cycle order is
DS 301 4.2.4.1 (SoC, PReq/PRes..., SoA, ASnd).
"""

from __future__ import annotations

import struct
import zlib
from collections import Counter
from pathlib import Path

import pytest
import tshark_util

from skinframes import ethercat, powerlink
from skinframes.check import CaptureReport, check_capture
from skinframes.ethercat import Command, Datagram, EcatFrame
from skinframes.findings import Severity
from skinframes.pcap import (
    LINKTYPE_CAN_SOCKETCAN,
    MarkedRecord,
    parse_capture,
    pcap_bytes,
    pcapng_bytes,
    read_capture,
)
from skinframes.powerlink import (
    ASnd,
    IdentResponse,
    NmtCommand,
    NmtCommandId,
    PReq,
    PRes,
    RequestedService,
    SoA,
    SoC,
    StatusResponse,
)

ETH = 14  # Ethernet header bytes: EPL/EtherCAT payload offsets below are relative to this


def epl(m: powerlink.EplMessage) -> bytes:
    return powerlink.frame(m).to_bytes()


def ecat(*datagrams: Datagram) -> bytes:
    return ethercat.frame(EcatFrame(datagrams)).to_bytes()


def check(frames: list[bytes], linktype: int = 1) -> CaptureReport:
    raw = pcap_bytes([(i * 10_000, f) for i, f in enumerate(frames)], linktype)
    return check_capture(parse_capture(raw, "hand-built"))


def found(report: CaptureReport, severity: Severity | None = None) -> list[tuple[int, str]]:
    """(record index, code) of every finding, optionally only those of one severity."""
    return [
        (f.index, f.finding.code)
        for f in report.findings
        if severity is None or f.finding.severity == severity
    ]


def clean_cycle(cns: int = 3, payload: bytes = bytes(range(32))) -> list[bytes]:
    frames = [epl(SoC(net_time_s=1_700_000_000, relative_time_us=1000))]
    for cn in range(1, cns + 1):
        frames += [epl(PReq(cn, bytes(4))), epl(PRes(cn, payload))]
    frames += [
        epl(SoA(RequestedService.IDENT_REQUEST, 1)),
        epl(ASnd(IdentResponse(poll_in_size=32), src=1)),
    ]
    return frames


def patch(frame: bytes, offset: int, value: bytes) -> bytes:
    return frame[:offset] + value + frame[offset + len(value) :]


# --- a clean capture --------------------------------------------------------------------------------
def test_clean_epl_cycles_have_no_errors_or_warnings() -> None:
    frames = clean_cycle() + clean_cycle() + [epl(SoC())]
    report = check(frames)
    assert report.errors == 0 and report.warnings == 0, found(report)
    assert report.total == len(frames) == report.counts["epl"]
    assert found(report) == []


def test_clean_ethercat_and_mixed_traffic() -> None:
    frames = [
        ecat(Datagram.logical(Command.LRD, 0, bytes(192), idx=1)),
        ecat(Datagram(Command.BRD, 0, 0x0130, bytes(2), wkc=3), Datagram(Command.NOP, 0, 0, b"")),
        # an ARP request: not ours, counted as other
        bytes.fromhex("ffffffffffff020000000001 0806") + bytes(46),
    ]
    report = check(frames)
    assert (report.errors, report.warnings) == (0, 0)
    assert report.counts == Counter({"ecat": 2, "other": 1})


@pytest.mark.parametrize(
    "name", sorted(p.name for p in Path(__file__).parents[2].glob("pcaps/*.pcap"))
)
def test_golden_pcaps_are_clean(name: str) -> None:
    path = Path(__file__).parents[2] / "pcaps" / name
    report = check_capture(read_capture(path))
    assert (report.errors, report.warnings) == (0, 0), found(report)


def test_non_ethernet_records_and_short_records() -> None:
    # a legal SocketCAN record (id 0, len 0, 8 padding bytes) is counted as "can" and is clean
    report = check([b"\x00" * 16], linktype=LINKTYPE_CAN_SOCKETCAN)
    assert report.counts == Counter({"can": 1}) and report.findings == []
    report = check([b"\x00" * 16], linktype=147)  # LINKTYPE_USER0: not ours to judge
    assert report.counts == Counter({"other": 1}) and report.findings == []
    report = check([epl(SoC()), b"\x01\x02\x03"])  # 3 bytes: not even an Ethernet header
    assert found(report, Severity.ERROR) == [(1, "eth.truncated")]


def test_skipped_records_are_errors() -> None:
    raw = pcap_bytes([(0, epl(SoC())), (1, epl(SoA()))])[:-5]
    report = check_capture(parse_capture(raw))
    assert report.total == 2 and report.counts["skipped"] == 1
    assert found(report, Severity.ERROR) == [(1, "pcap.skipped")]


# --- field consistency ------------------------------------------------------------------------------
def test_pres_size_past_the_frame_is_an_error() -> None:
    good = epl(PRes(1, bytes(8)))
    assert struct.unpack_from("<H", good, ETH + 8)[0] == 8  # Size field where DS 301 puts it
    bad = patch(good, ETH + 8, struct.pack("<H", 192))  # frames.md bad.pcap #1
    report = check([good, bad])
    assert [i for i, _ in found(report, Severity.ERROR)] == [1]
    assert report.errors == 1


def test_preq_size_within_the_frame_is_not_an_error() -> None:
    # Size 8 with 40 bytes present: tshark reads it cleanly (frames.md bad.pcap #2); the rest is
    # padding/trailer, not an error
    frame = epl(PReq(1, bytes(8))) + bytes(32)
    report = check([frame])
    assert report.errors == 0


def test_ecat_header_length_disagreeing_is_an_error() -> None:
    good = ecat(Datagram.logical(Command.LRD, 0x10000, bytes(4)))
    (header,) = struct.unpack_from("<H", good, ETH)
    assert header == 0x1000 | (12 + 4)  # type 1, length = one 16-byte datagram
    for length in (15, 17, 40, 0):
        bad = patch(good, ETH, struct.pack("<H", 0x1000 | length))
        report = check([good, bad])
        assert found(report, Severity.ERROR) == [(1, "ecat.header.length")], length


def test_more_bit_on_the_last_datagram_is_flagged() -> None:
    good = ecat(
        Datagram(Command.FPRD, 0x1001, 0x130, bytes(2)), Datagram(Command.BRD, 0, 0, bytes(2))
    )
    # the second datagram starts at 2 + 14; its length word is at +6, M is bit 15
    first_word = struct.unpack_from("<H", good, ETH + 2 + 6)[0]
    second_at = ETH + 2 + 14
    second_word = struct.unpack_from("<H", good, second_at + 6)[0]
    assert (first_word & 0x8000, second_word & 0x8000) == (0x8000, 0)
    bad = patch(good, second_at + 6, struct.pack("<H", second_word | 0x8000))
    report = check([good, bad])
    assert found(report) == [(1, "ecat.more.last")]
    assert report.findings[0].finding.severity >= Severity.WARNING


def test_more_bit_cleared_early_leaves_bytes_unexplained() -> None:
    # M clear on the first of two datagrams: the chain ends early and the header length disagrees
    good = ecat(
        Datagram(Command.FPRD, 0x1001, 0x130, bytes(2)), Datagram(Command.BRD, 0, 0, bytes(2))
    )
    word = struct.unpack_from("<H", good, ETH + 2 + 6)[0]
    bad = patch(good, ETH + 2 + 6, struct.pack("<H", word & 0x7FFF))
    assert check([bad]).errors >= 1


def test_datagram_running_past_the_frame_is_an_error() -> None:
    good = ecat(Datagram.logical(Command.LRD, 0, bytes(4)))
    bad = patch(good, ETH + 2 + 6, struct.pack("<H", 200))  # length 200 in a 60-byte frame
    assert found(check([bad]), Severity.ERROR) == [(0, "ecat.undecodable")]


# --- padding ----------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "frame",
    [epl(SoC()), epl(SoA()), ecat(Datagram(Command.BRD, 0, 0x130, bytes(2)))],
    ids=["soc", "soa", "ecat"],
)
def test_nonzero_padding_is_flagged(frame: bytes) -> None:
    assert len(frame) == 60 and frame[-1] == 0  # padded to the minimum with zeros
    assert check([frame]).findings == []
    bad = frame[:-1] + b"\xee"
    report = check([bad])
    assert found(report) == [(0, "eth.padding.nonzero")]
    assert report.findings[0].finding.severity == Severity.WARNING


def test_frame_with_its_fcs_is_not_flagged_as_bad_padding() -> None:
    frame = epl(SoC())
    with_fcs = frame + struct.pack("<I", zlib.crc32(frame))  # IEEE 802.3 CRC-32, LSB first
    report = check([with_fcs])
    assert found(report) == [(0, "eth.fcs")]
    assert report.findings[0].finding.severity == Severity.INFO


# --- node ids ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "message",
    [
        SoC(src=17),  # SoC comes from the MN (240)
        SoC(dest=1),  # ... to broadcast
        SoA(src=1),
        PReq(0),  # PReq goes to a CN (1..239)
        PReq(250),
        PReq(240),
        PReq(255),
        PReq(1, src=17),  # ... from the MN
        PRes(1, dest=240),  # PRes is broadcast (255)
        PRes(1, dest=2),
        PRes(0),  # PRes from a CN or the MN
        PRes(245),
        ASnd(StatusResponse(), src=0),
        ASnd(NmtCommand(NmtCommandId.START_NODE), dest=250),
    ],
    ids=repr,
)
def test_wrong_node_ids_are_errors(message: powerlink.EplMessage) -> None:
    report = check([epl(message)])
    assert "epl.node_id" in {c for _, c in found(report, Severity.ERROR)}, found(report)


@pytest.mark.parametrize(
    "message",
    [
        SoC(),
        SoA(RequestedService.STATUS_REQUEST, 239),
        PReq(1),
        PReq(239),
        PRes(1),
        PRes(239),
        PRes(240),  # the MN's own PRes (DS 301 4.2.4.1.1.1)
        ASnd(StatusResponse(), src=239),
        ASnd(NmtCommand(NmtCommandId.START_NODE), dest=255),
        ASnd(NmtCommand(NmtCommandId.START_NODE), dest=253),  # diagnostic device
    ],
    ids=repr,
)
def test_right_node_ids_are_accepted(message: powerlink.EplMessage) -> None:
    assert check([epl(message)]).errors == 0


# --- cycle order ------------------------------------------------------------------------------------
def test_asnd_in_the_isochronous_phase_is_an_error() -> None:
    frames = [
        epl(SoC()),
        epl(PReq(1)),
        epl(ASnd(StatusResponse(), src=1)),  # before the SoA
        epl(PRes(1)),
        epl(SoA()),
    ]
    assert found(check(frames), Severity.ERROR) == [(2, "epl.cycle.order")]


@pytest.mark.parametrize("late", [PReq(1), PRes(1)], ids=["preq", "pres"])
def test_poll_after_soa_is_an_error(late: powerlink.EplMessage) -> None:
    frames = [epl(SoC()), epl(PReq(1)), epl(PRes(1)), epl(SoA()), epl(late)]
    assert found(check(frames), Severity.ERROR) == [(4, "epl.cycle.order")]


def test_a_new_soc_starts_a_new_cycle() -> None:
    frames = [epl(SoC()), epl(SoA()), epl(SoC()), epl(PReq(1)), epl(PRes(1)), epl(SoA())]
    assert check(frames).findings == []


def test_missing_soa_and_unpolled_pres_are_warnings() -> None:
    report = check([epl(SoC()), epl(PReq(1)), epl(PRes(1)), epl(SoC())])
    assert found(report) == [(3, "epl.cycle.no_soa")]
    assert report.warnings == 1 and report.errors == 0
    report = check([epl(SoC()), epl(PReq(1)), epl(PRes(2)), epl(SoA())])
    assert found(report) == [(2, "epl.cycle.unpolled")]
    assert report.warnings == 1 and report.errors == 0


def test_two_asnd_after_one_soa_is_only_information() -> None:
    frames = [
        epl(SoC()),
        epl(SoA()),
        epl(ASnd(StatusResponse(), src=1)),
        epl(ASnd(StatusResponse(), src=2)),
    ]
    report = check(frames)
    assert (report.errors, report.warnings) == (0, 0)
    assert found(report) == [(3, "epl.cycle.asnd_count")]


def test_json_document_lists_findings_from_a_severity_on_and_counts_them_all() -> None:
    frames = [epl(SoC()), epl(PReq(1)), epl(PRes(2)), epl(SoA())]
    frames += [epl(ASnd(StatusResponse(), src=1)), epl(ASnd(StatusResponse(), src=2))]
    report = check(frames)
    doc = report.to_json()
    assert list(doc) == ["path", "records", "counts", "errors", "warnings", "findings"]
    assert (doc["path"], doc["records"], doc["counts"]) == ("hand-built", 6, {"epl": 6})
    assert (doc["errors"], doc["warnings"]) == (0, 1)
    assert [(f["index"], f["severity"], f["code"]) for f in doc["findings"]] == [
        (2, "warning", "epl.cycle.unpolled"),
        (5, "info", "epl.cycle.asnd_count"),
    ]
    only = report.to_json(Severity.WARNING)
    assert [f["code"] for f in only["findings"]] == ["epl.cycle.unpolled"]
    assert only["warnings"] == 1  # the counts are of every finding
    assert report.at_least(Severity.ERROR) == []


def test_before_the_first_soc_nothing_is_judged() -> None:
    # a capture may start anywhere in a cycle
    report = check([epl(PRes(1)), epl(ASnd(StatusResponse(), src=1)), epl(SoC())])
    assert report.findings == []


# --- tshark agrees on what is an error ----------------------------------------------------------
@pytest.mark.tshark
def test_tshark_flags_the_pres_size_error_too(tshark: str, tmp_path: Path) -> None:
    good = epl(PRes(1, bytes(8)))
    bad = patch(good, ETH + 8, struct.pack("<H", 192))
    path = tmp_path / "size.pcap"
    path.write_bytes(pcap_bytes([(0, good), (1000, bad)]))
    flagged = {int(line.split("\t")[0]) - 1 for line in tshark_util.problems(tshark, path)}
    ours = {
        f.index
        for f in check_capture(read_capture(path)).findings
        if f.finding.severity == Severity.ERROR
    }
    assert flagged == ours == {1}


# --- the real captures --------------------------------------------------------------------------
# What check finds in the third-party captures (none is an error), and why each finding is right:
# - EPL_Example: SoC/SoA with non-zero reserved bytes (INFO; B&R's MN, tshark ignores reserved
#   fields), and PRes frames of 280 bytes that carry Size 32 (224 bytes after the PDO: INFO trailer;
#   tshark: 0 expert items).
# - 1CN: openPOWERLINK captured on the sending host, so SoC (36 bytes) and SoA (54) are unpadded
#   (INFO); its 6 StatusResponses are 72-byte frames, the size openPOWERLINK builds (no finding).
# - MultiWriteRead: every frame ends with its correct FCS (INFO). tshark calls 2 frames Malformed
#   because its multi-parameter SDO parser reads the FCS as data; we recognise the CRC.
# - SOEM: the master sends from 01:01:01:01:01:01, a group address (WARNING; tshark warns on all 580).
# - ethercrab replay: TX frames captured unpadded on the host (INFO).
# - eth.overlap (WARNING): the MN's frames stamped closer than the wire allows: EPL_Example frames
#   223/224 and 840/841 (0-based) SoC -> PReq 5 us apart, a 60-byte frame needs 6.72 us; 1CN
#   frame 359, 6.683 us after 358 (captured on the sending host, stamped in software).
REAL = {
    "epl-viz_EPL_Example.cap": {"epl.reserved": 251, "eth.trailer": 251, "eth.overlap": 2},
    "epl-viz_1CN.pcapng": {"eth.unpadded": 552, "eth.overlap": 1},
    # 4 of the 7 frames carry a Write/ReadMultipleParam segment with bytes after it (INFO)
    "epl-viz_MultiWriteRead_example.pcapng": {"eth.fcs": 7, "epl.sdo.multi_param.padding": 4},
    "ethercrab_replay-ek1100-el2828-el2889.pcapng": {"eth.unpadded": 1789},
    "ethercrab_soem-sdinfo-ek1100-el1004.pcapng": {"eth.unpadded": 290, "eth.src.group": 580},
}


@pytest.mark.parametrize("name", sorted(REAL))
def test_real_captures_have_no_errors(shared_captures: Path, name: str) -> None:
    report = check_capture(read_capture(shared_captures / name))
    assert report.errors == 0, [f for f in report.findings if f.finding.severity == Severity.ERROR][
        :5
    ]
    assert Counter(f.finding.code for f in report.findings) == Counter(REAL[name])
    warnings = {f.finding.code for f in report.findings if f.finding.severity == Severity.WARNING}
    overlap = {"eth.overlap"} if "epl-viz_1CN" in name or "EPL_Example" in name else set()
    assert warnings == ({"eth.src.group"} if "soem" in name else overlap)


def test_multiwriteread_frames_really_end_with_their_fcs(shared_captures: Path) -> None:
    # independent of the decoder: the last 4 bytes are the CRC-32 of the rest, least significant first
    capture = read_capture(shared_captures / "epl-viz_MultiWriteRead_example.pcapng")
    assert len(capture.records) == 7
    for r in capture.records:
        assert r.data[-4:] == struct.pack("<I", zlib.crc32(r.data[:-4]))


# --- SocketCAN records and the file itself (issue 11, Build 6) -------------------------------------
def socketcan(can_id: int, length: int, data: bytes, flags: int = 0) -> bytes:
    """struct can_frame as LINKTYPE_CAN_SOCKETCAN stores it: id big-endian, len, flags, 2 pad."""
    return struct.pack(">IBBxx", can_id, length, flags) + data


def test_socketcan_records_are_checked() -> None:
    good = socketcan(0x410, 8, bytes(range(8)))
    fd = socketcan(0x411, 64, bytes(64), flags=0x04)  # CANFD_FDF: up to 64 bytes
    bad_len = socketcan(0x412, 9, bytes(8))  # a classic frame carries at most 8 bytes
    short = socketcan(0x413, 8, bytes(4))  # len 8, 4 data bytes present
    stub = b"\x00\x00\x04"  # not even the 8-byte header
    report = check([good, fd, bad_len, short, stub], linktype=LINKTYPE_CAN_SOCKETCAN)
    assert report.counts == Counter({"can": 5})
    assert found(report, Severity.ERROR) == [
        (2, "can.socketcan"),
        (3, "can.socketcan"),
        (4, "can.socketcan"),
    ]
    messages = [f.finding.message for f in report.findings]
    assert "len 9 > 8" in messages[0] and "len 8 needs 16" in messages[1]


def test_file_findings_reach_check_without_counting_as_records() -> None:
    import gzip

    raw = pcap_bytes([(0, epl(SoC())), (100_000, epl(SoA()))])  # 100 us apart: no overlap
    report = check_capture(parse_capture(gzip.compress(raw) + b"junk", "trailing.gz"))
    assert report.total == 2 and report.counts["skipped"] == 0
    assert found(report) == [(-1, "pcap.gzip_trailing")]
    assert report.findings[0].frame == 0
    assert report.to_json()["findings"][0]["frame"] == 0


def test_pcapng_block_damage_is_a_named_finding() -> None:
    raw = pcapng_bytes([MarkedRecord(0, epl(SoC())), MarkedRecord(1, epl(SoA()))])
    broken = raw[:-4] + struct.pack("<I", 0xDEAD)  # the last block's trailing length
    report = check_capture(parse_capture(broken))
    assert found(report, Severity.ERROR) == [(1, "pcapng.block")]


def test_unpolled_pres_after_soc_names_no_none() -> None:
    frames = [epl(SoC()), epl(PRes(src=3))]
    report = check(frames)
    (f,) = [f.finding for f in report.findings if f.finding.code == "epl.cycle.unpolled"]
    assert "None" not in f.message and "no PReq" in f.message


@pytest.mark.parametrize("suffix", [".pcap", ".pcapng"])
def test_a_closed_ring_in_one_stream_is_not_an_overlap(tmp_path: Path, suffix: str) -> None:
    # the master sends each LRD frame from both ports; a frame coming back through the ring keeps
    # the source address of the copy sent from the other port, and a classic pcap has one stream
    # for both ports: its return is not a second frame from that sender
    from emulator import WIRE, simulate_ecat

    path = tmp_path / f"ring{suffix}"
    simulate_ecat(160, 192, WIRE, closed_ring=True, cycles=3, pcap=path)
    report = check_capture(read_capture(path))
    assert [f for f in report.findings if f.finding.code == "eth.overlap"] == []
    assert report.errors == report.warnings == 0
