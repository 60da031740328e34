"""Ethernet framing: sizes, FCS, MAC parsing, padding, and the header codec (IEEE 802.3-2018)."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from skinframes import decode_frame, ethercat, ethernet, powerlink, protocol_of
from skinframes.errors import FieldRangeError, FrameTooLargeError, TruncatedError
from skinframes.ethernet import EthernetFrame
from skinframes.vlan import TPID_STAG, VlanTag, tag_schema

macs = st.binary(min_size=6, max_size=6)
ethertypes = st.integers(0, 0xFFFF)


def sized_binary(min_size: int, max_size: int) -> st.SearchStrategy[bytes]:
    """Bytes whose length is drawn uniformly (st.binary alone favours short values)."""
    return st.integers(min_size, max_size).flatmap(lambda n: st.binary(min_size=n, max_size=n))


def crc32_bitwise(data: bytes) -> int:
    """CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320) bit by bit: independent of zlib."""
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0xEDB88320 if crc & 1 else 0)
    return crc ^ 0xFFFFFFFF


# --- hand-computed sizes (802.3 clause 3/4; the paper's E_ov = 26) -------------------------------
def test_size_constants() -> None:
    assert ethernet.HEADER_BYTES == 14  # 6 + 6 + 2
    assert ethernet.OVERHEAD_BYTES == 26  # 8 preamble/SFD + 14 header + 4 FCS
    assert ethernet.MIN_FRAME_BYTES == 60  # 64-byte minFrameSize without the 4-byte FCS
    assert ethernet.MAX_FRAME_BYTES == 1514
    assert ethernet.MIN_PAYLOAD_BYTES == 46
    assert ethernet.MAX_PAYLOAD_BYTES == 1500
    assert ethernet.ETHERTYPE_EPL == 0x88AB
    assert ethernet.ETHERTYPE_ECAT == 0x88A4


@pytest.mark.parametrize(
    ("frame_bytes", "on_wire"),
    [
        (1444, 1456),  # 8 + 1444 + 4
        (1514, 1526),  # the largest untagged frame
        (60, 72),  # the minimum: 8 + 60 + 4 = 72 = 64-byte frame + preamble
        (14, 72),  # padded to 60 first
        (0, 72),
        (61, 73),
    ],
)
def test_wire_bytes(frame_bytes: int, on_wire: int) -> None:
    assert ethernet.wire_bytes(frame_bytes) == on_wire


@given(st.integers(0, 9000))
def test_wire_bytes_is_preamble_padded_frame_and_fcs(n: int) -> None:
    assert ethernet.wire_bytes(n) == 8 + max(n, 60) + 4


@given(st.integers(0, 2000))
def test_padding_for(n: int) -> None:
    assert ethernet.padding_for(n) == (60 - n if n < 60 else 0)


# --- FCS -------------------------------------------------------------------------------------------
def test_fcs_check_value() -> None:
    # the CRC-32 "check" value of the CRC catalogue: CRC-32 of b"123456789" is 0xCBF43926, and the
    # FCS goes on the wire least significant byte first
    assert crc32_bitwise(b"123456789") == 0xCBF43926
    assert ethernet.fcs(b"123456789") == bytes.fromhex("2639f4cb")
    assert ethernet.fcs(b"") == bytes(4)


@given(st.binary(max_size=200))
def test_fcs_matches_bitwise_crc32(data: bytes) -> None:
    assert ethernet.fcs(data) == struct.pack("<I", crc32_bitwise(data))


@given(st.binary(max_size=200))
def test_fcs_residue(data: bytes) -> None:
    # a receiver running the CRC over frame + FCS always ends at the magic residue 0x2144DF1C
    # (0xDEBB20E3 before the final inversion)
    assert crc32_bitwise(data + ethernet.fcs(data)) == 0x2144DF1C


# --- MAC addresses ---------------------------------------------------------------------------------
def test_mac_parses_both_separators() -> None:
    assert ethernet.mac("02:00:00:00:00:01") == b"\x02\x00\x00\x00\x00\x01"
    assert ethernet.mac("01-11-1E-00-00-04") == b"\x01\x11\x1e\x00\x00\x04"
    assert ethernet.format_mac(b"\x01\x11\x1e\x00\x00\x04") == "01:11:1e:00:00:04"


@given(macs)
def test_mac_format_round_trip(addr: bytes) -> None:
    text = ethernet.format_mac(addr)
    assert len(text) == 17
    assert ethernet.mac(text) == addr


@pytest.mark.parametrize(
    "text",
    ["", "02:00:00:00:00", "02:00:00:00:00:01:02", "zz:00:00:00:00:00", "100:00:00:00:00:00", "-1"],
)
def test_bad_mac_text_raises_field_range_error(text: str) -> None:
    with pytest.raises(FieldRangeError):
        ethernet.mac(text)


def test_is_group() -> None:
    assert ethernet.is_group(b"\xff" * 6)
    assert ethernet.is_group(bytes.fromhex("01111e000001"))  # EPL SoC multicast
    assert ethernet.is_group(bytes.fromhex("010101010101"))  # SOEM's source MAC (frames.md 0)
    assert not ethernet.is_group(bytes.fromhex("020000000001"))
    assert not ethernet.is_group(bytes.fromhex("00005e005301"))


# --- EthernetFrame ---------------------------------------------------------------------------------
@given(macs, macs, ethertypes, sized_binary(0, 1500))
def test_to_bytes_layout(dst: bytes, src: bytes, ethertype: int, payload: bytes) -> None:
    frame = EthernetFrame(dst, src, payload, ethertype)
    want = dst + src + ethertype.to_bytes(2, "big") + payload
    want += bytes(max(0, 60 - len(want)))
    assert frame.to_bytes() == want
    assert frame.payload_bytes == payload
    assert frame.wire_bytes() == 8 + len(want) + 4


@given(macs, macs, ethertypes, st.binary(max_size=100), st.binary(max_size=30))
def test_explicit_padding_is_kept_verbatim(
    dst: bytes, src: bytes, ethertype: int, payload: bytes, pad: bytes
) -> None:
    frame = EthernetFrame(dst, src, payload, ethertype, padding=pad)
    assert frame.to_bytes() == dst + src + ethertype.to_bytes(2, "big") + payload + pad


@given(
    st.binary(max_size=12).filter(lambda b: len(b) != 6), macs, st.booleans(), st.binary(max_size=8)
)
def test_bad_mac_length_raises(bad: bytes, good: bytes, bad_is_dst: bool, payload: bytes) -> None:
    dst, src = (bad, good) if bad_is_dst else (good, bad)
    with pytest.raises(FieldRangeError):
        EthernetFrame(dst, src, payload, 0x0800)


@given(st.one_of(st.integers(max_value=-1), st.integers(min_value=0x10000)))
def test_ethertype_out_of_range(ethertype: int) -> None:
    with pytest.raises(FieldRangeError):
        EthernetFrame(bytes(6), bytes(6), b"", ethertype)


def test_raw_payload_needs_an_ethertype() -> None:
    with pytest.raises(FieldRangeError):
        EthernetFrame(bytes(6), bytes(6), b"\x01\x02")


@given(st.integers(1501, 3000))
def test_payload_over_1500_bytes_is_too_large(n: int) -> None:
    with pytest.raises(FrameTooLargeError):
        EthernetFrame(bytes(6), bytes(6), bytes(n), 0x0800).to_bytes()


@given(st.binary(max_size=13))
def test_from_bytes_needs_the_header(data: bytes) -> None:
    with pytest.raises(TruncatedError):
        EthernetFrame.from_bytes(data)


@given(sized_binary(14, 1514))
def test_from_bytes_splits_the_header(data: bytes) -> None:
    frame = EthernetFrame.from_bytes(data)
    assert frame.dst == data[:6]
    assert frame.src == data[6:12]
    assert frame.ethertype == (data[12] << 8) | data[13]
    assert frame.payload == data[14:]
    assert frame.to_bytes() == data


@given(sized_binary(14, 3000))
def test_from_bytes_to_bytes_is_identity_at_any_length(data: bytes) -> None:
    # captures may hold VLAN-tagged or jumbo frames longer than 1514 bytes: nothing is lost
    assert EthernetFrame.from_bytes(data).to_bytes() == data


def test_a_vlan_tagged_full_size_frame_survives_capture_decoding() -> None:
    # 802.1Q adds 4 bytes: a full-size tagged frame is 1518 bytes as captured
    raw = bytes.fromhex("ffffffffffff020000000001") + b"\x81\x00\x00\x05\x08\x00" + bytes(1500)
    assert len(raw) == 1518
    frame = decode_frame(raw)
    assert protocol_of(frame) == "other"
    # the tag is peeled (IEEE 802.1Q-2018 9.5): the EtherType is the one after it
    assert (frame.tags, frame.ethertype) == ((VlanTag(5),), 0x0800)
    assert frame.to_bytes() == raw


def test_tagged_epl_and_ecat_frames_decode_like_untagged_ones() -> None:
    soa = powerlink.frame(powerlink.SoA())
    lrd = ethercat.frame(
        ethercat.EcatFrame((ethercat.Datagram.logical(ethercat.Command.LRD, 0, bytes(192)),))
    )
    for plain in (soa, lrd):
        for tags in ((VlanTag(7, pcp=5),), (VlanTag(100, tpid=TPID_STAG), VlanTag(7, dei=True))):
            tagged = EthernetFrame(plain.dst, plain.src, plain.payload, tags=tags)
            raw = tagged.to_bytes()
            # 4 bytes per tag between source MAC and EtherType; padding counts them
            assert raw[12 : 12 + 4 * len(tags)] == b"".join(t.to_bytes() for t in tags)
            assert len(raw) == max(60, 14 + 4 * len(tags) + len(plain.payload_bytes))
            back = decode_frame(raw, strict=True)
            assert (back.tags, back.payload, back.to_bytes()) == (tags, plain.payload, raw)
            assert tagged.wire_bytes() == 8 + max(60, len(raw)) + 4


@pytest.mark.parametrize("tpid", [0x8100, 0x88A8, 0x9100])
def test_vlan_tag_bytes_equal_the_schema(tpid: int) -> None:
    tag = VlanTag(0xABC, pcp=6, dei=True, tpid=tpid)
    parsed = tag_schema.parse(tag.to_bytes())
    assert (parsed.tpid, parsed.tci.pcp, parsed.tci.dei, parsed.tci.vid) == (tpid, 6, True, 0xABC)
    assert tag_schema.build(parsed) == tag.to_bytes()
    assert VlanTag.from_bytes(tag.to_bytes()) == tag


@pytest.mark.parametrize(
    "kwargs", [{"vid": 4096}, {"vid": -1}, {"vid": 1, "pcp": 8}, {"vid": 1, "tpid": 0x0800}]
)
def test_vlan_tag_fields_out_of_range(kwargs: dict[str, int]) -> None:
    with pytest.raises(FieldRangeError):
        VlanTag(**kwargs)


# --- bit errors ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("frame", "bit", "expected"),
    [
        ("0000", 0, "0100"),  # bit 0: least significant bit of byte 0
        ("0000", 7, "8000"),
        ("0000", 8, "0001"),  # bit 8: least significant bit of byte 1
        ("0000", 15, "0080"),
        ("ffff", 9, "fffd"),
        ("a5", 3, "ad"),  # 1010 0101 -> 1010 1101
    ],
)
def test_flip_bit_by_hand(frame: str, bit: int, expected: str) -> None:
    assert ethernet.flip_bit(bytes.fromhex(frame), bit) == bytes.fromhex(expected)


@given(sized_binary(1, 1514), st.data())
def test_flip_bit_changes_one_bit_and_the_fcs(frame: bytes, data: st.DataObject) -> None:
    bit = data.draw(st.integers(0, 8 * len(frame) - 1))
    flipped = ethernet.flip_bit(frame, bit)
    assert len(flipped) == len(frame)
    diff = int.from_bytes(frame, "little") ^ int.from_bytes(flipped, "little")
    assert diff == 1 << bit
    assert ethernet.fcs(flipped) != ethernet.fcs(frame)  # CRC-32 detects every 1-bit error
    assert ethernet.flip_bit(flipped, bit) == frame


@pytest.mark.parametrize(
    ("frame", "bit"), [(b"", 0), (b"\x00", -1), (b"\x00", 8), (bytes(60), 480)]
)
def test_flip_bit_out_of_range(frame: bytes, bit: int) -> None:
    with pytest.raises(FieldRangeError):
        ethernet.flip_bit(frame, bit)


@pytest.mark.parametrize("size", [0, 1, 24, 27, 28, 36, 192, 1490])
@pytest.mark.parametrize("ntags", [1, 2])
def test_tag_frames_batch_equals_the_codec(size: int, ntags: int) -> None:
    import numpy as np

    from skinframes.vlan import tag_frames

    tags = (VlanTag(100, tpid=TPID_STAG), VlanTag(7, pcp=5))[-ntags:]
    messages = [
        powerlink.PRes(i + 1, bytes(range(size % 256)) * (size // 256) + bytes(size % 256))
        for i in range(3)
    ]
    plain = [powerlink.frame(m) for m in messages]
    rows = np.array([np.frombuffer(f.to_bytes(), np.uint8) for f in plain])
    got = tag_frames(rows, tags, len(messages[0].to_bytes()))
    want = [EthernetFrame(f.dst, f.src, f.payload, tags=tags).to_bytes() for f in plain]
    assert [bytes(r) for r in got] == want
