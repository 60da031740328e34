"""Fuzzing the decoders: random and mutated bytes raise nothing outside DecodeError, and capture
mode gives back every byte it was handed.

Three kinds of input reach progressively deeper code: plain random bytes; an Ethernet header with
the EPL or EtherCAT EtherType and a random tail (whose first bytes are steered to real message
types and frame headers); and valid frames (hand-built vectors and hypothesis-built frames) with
bytes flipped, replaced, inserted, cut off or appended.
"""

from __future__ import annotations

import gzip
import ipaddress
import struct
from collections.abc import Callable

import pytest
from data.vectors import VECTORS
from hypothesis import given, settings
from hypothesis import strategies as st

from skinframes import decode_frame, ethercat, ethernet, powerlink
from skinframes.errors import DecodeError, PcapFormatError, TruncatedError
from skinframes.ethercat import Command, Datagram, EcatFrame
from skinframes.ethernet import EthernetFrame
from skinframes.pcap import parse_capture, pcap_bytes
from skinframes.powerlink import (
    ASnd,
    ErrorEntry,
    IdentResponse,
    NmtCommand,
    NmtRequest,
    PReq,
    PRes,
    RawMessage,
    RawService,
    Sdo,
    SdoCommand,
    SoA,
    SoC,
    StatusResponse,
    SyncResponse,
)
from skinframes.taxel import patch_from_bytes

# a multiple of the profile's count ("dev" 100, "ci" 400): fuzzing wants more examples
FUZZ = settings(max_examples=3 * settings().max_examples)

u8 = st.integers(0, 0xFF)
u16 = st.integers(0, 0xFFFF)
u32 = st.integers(0, 0xFFFFFFFF)


def sized_binary(min_size: int, max_size: int) -> st.SearchStrategy[bytes]:
    """Bytes whose length is drawn uniformly (st.binary alone favours short values)."""
    return st.integers(min_size, max_size).flatmap(lambda n: st.binary(min_size=n, max_size=n))


any_bytes = st.one_of(st.binary(max_size=100), sized_binary(0, 1600), sized_binary(1500, 3100))
frames_14 = st.one_of(st.binary(min_size=14, max_size=100), sized_binary(14, 3100))

# --- structured inputs ------------------------------------------------------------------------------
MAC = bytes.fromhex("020000000a01")
EPL_HEAD = bytes(6) + MAC + b"\x88\xab"
ECAT_HEAD = b"\xff" * 6 + MAC + b"\x88\xa4"


@st.composite
def epl_tails(draw: st.DrawFn) -> bytes:
    """EPL bytes: a real (or reserved-bit) MessageType, a real ServiceID for ASnd, random rest."""
    mtype = draw(st.one_of(st.sampled_from([1, 3, 4, 5, 6, 7, 13, 0x84, 0x8D]), u8))
    rest = bytearray(draw(st.one_of(st.binary(max_size=60), sized_binary(0, 3000))))
    if mtype == 6 and len(rest) >= 3:
        rest[2] = draw(st.one_of(st.integers(1, 6), st.integers(0xA0, 0xFE), u8))
    if mtype in (3, 4) and len(rest) >= 9:  # a Size that fits the bytes present, often
        size = draw(st.integers(0, max(0, len(rest) - 9)))
        rest[7:9] = size.to_bytes(2, "little")
    if mtype == 5 and len(rest) >= 4:
        rest[3] = draw(st.one_of(st.just(6), u8))
    return bytes((mtype,)) + bytes(rest)


@st.composite
def ecat_tails(draw: st.DrawFn) -> bytes:
    """EtherCAT bytes: a type-1 header and datagram headers with plausible lengths."""
    out = bytearray()
    count = draw(st.integers(0, 6))
    for i in range(count):
        n = draw(st.one_of(st.integers(0, 40), st.integers(0, 1600)))
        more = draw(st.one_of(st.just(i < count - 1), st.booleans()))
        flags = draw(st.one_of(st.just(0), st.sampled_from([0x4000, 0x0800, 0x1000, 0x2000])))
        cmd = draw(st.one_of(st.sampled_from(Command), u8))
        word = n | (0x8000 if more else 0) | flags
        out += struct.pack("<BBHHHH", cmd, draw(u8), draw(u16), draw(u16), word, draw(u16))
        out += draw(st.binary(min_size=n, max_size=n)) + struct.pack("<H", draw(u16))
    length = draw(st.one_of(st.just(len(out) & 0x7FF), st.integers(0, 0x7FF)))
    header = length | draw(st.sampled_from([0x1000, 0x1800, 0x2000, 0x0000]))
    out = bytearray(struct.pack("<H", header)) + out
    if draw(st.booleans()):
        out = out[: draw(st.integers(0, len(out)))]
    return bytes(out + draw(st.binary(max_size=50)))


structured = st.one_of(
    epl_tails().map(lambda t: EPL_HEAD + t),
    ecat_tails().map(lambda t: ECAT_HEAD + t),
    st.binary(max_size=60).map(lambda t: EPL_HEAD + t),
    st.binary(max_size=60).map(lambda t: ECAT_HEAD + t),
)

# valid frames to mutate: the hand-built vectors and frames the encoders build
addresses = st.builds(ipaddress.IPv4Address, u32)
epl_messages = st.one_of(
    st.builds(SoC, dest=u8, src=u8, flags=u8, net_time_s=u32, relative_time_us=u32),
    st.builds(PReq, dest=u8, payload=st.binary(max_size=200), flags1=u8, pdo_version=u8),
    st.builds(PRes, src=u8, payload=st.binary(max_size=200), nmt_status=u8, flags2=u8),
    st.builds(SoA, requested_service=u8.filter(lambda s: s != 6), requested_target=u8),
    st.builds(SoA, requested_service=st.just(6), sync_request=st.binary(min_size=30, max_size=30)),
    st.builds(
        ASnd,
        service=st.one_of(
            st.builds(
                IdentResponse, ip_address=addresses, host_name=st.just(b"cn".ljust(32, b"\0"))
            ),
            st.builds(
                StatusResponse,
                error_entries=st.lists(
                    st.builds(ErrorEntry, st.integers(1, 0xFFFF), u16), max_size=3
                ).map(tuple),
            ),
            st.builds(NmtRequest, u8, u8, st.binary(max_size=20)),
            st.builds(NmtCommand, u8, st.binary(max_size=40)),
            st.builds(
                Sdo,
                receive_sequence=st.integers(0, 63),
                send_con=st.integers(0, 3),
                command=st.none()
                | st.builds(SdoCommand, u8, st.integers(1, 0xFF), st.binary(max_size=40)),
            ),
            st.builds(SyncResponse, sync_status=u32),
            st.builds(RawService, st.integers(0xA0, 0xFE), st.binary(max_size=40)),
        ),
        dest=u8,
        src=u8,
    ),
    st.builds(RawMessage, st.sampled_from([7, 13]), u8, u8, st.binary(max_size=60)),
)
ecat_messages = st.lists(
    st.builds(
        Datagram,
        cmd=st.sampled_from(Command),
        adp=u16,
        ado=u16,
        data=st.binary(max_size=60),
        idx=u8,
        wkc=u16,
        circulating=st.booleans(),
    ),
    min_size=1,
    max_size=8,
).map(lambda ds: EcatFrame(tuple(ds)))
valid_frames = st.one_of(
    st.sampled_from([data for _, data in VECTORS.values()]),
    epl_messages.map(lambda m: powerlink.frame(m).to_bytes()),
    ecat_messages.map(lambda f: ethercat.frame(f).to_bytes()),
)


@st.composite
def mutated_frames(draw: st.DrawFn) -> bytes:
    """A valid frame with one to a few edits: flips, replacements, inserts, cuts, appends."""
    data = bytearray(draw(valid_frames))
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["flip", "set", "insert", "cut", "append", "delete", "fcs"]))
        # favour the headers, where the decoders branch
        pos = draw(st.one_of(st.integers(14, 40), st.integers(0, max(0, len(data) - 1))))
        pos = min(pos, max(0, len(data) - 1))
        if op == "flip" and data:
            data[pos] ^= 1 << draw(st.integers(0, 7))
        elif op == "set" and data:
            data[pos] = draw(u8)
        elif op == "insert":
            data[pos:pos] = draw(st.binary(min_size=1, max_size=20))
        elif op == "cut":
            data = data[: draw(st.integers(0, len(data)))]
        elif op == "append":
            data += draw(st.one_of(st.binary(min_size=1, max_size=20), st.just(bytes(4))))
        elif op == "delete":
            del data[pos : pos + draw(st.integers(1, 20))]
        elif op == "fcs":  # a capture that kept the frame check sequence
            data += ethernet.fcs(bytes(data))
    return bytes(data)


fuzz_frames = st.one_of(frames_14, structured, mutated_frames().filter(lambda b: len(b) >= 14))

# --- the properties ---------------------------------------------------------------------------------
DECODERS: dict[str, Callable[[bytes], object]] = {
    "powerlink.decode strict": lambda b: powerlink.decode(b, strict=True),
    "powerlink.decode capture": lambda b: powerlink.decode(b, strict=False),
    "ethercat.decode strict": lambda b: ethercat.decode(b, strict=True),
    "ethercat.decode capture": lambda b: ethercat.decode(b, strict=False),
    "decode_frame strict": lambda b: decode_frame(b, strict=True),
    "decode_frame capture": lambda b: decode_frame(b, strict=False),
    "EthernetFrame.from_bytes": EthernetFrame.from_bytes,
    "parse_capture": lambda b: parse_capture(b).records,  # streams: read every record
    "patch_from_bytes": patch_from_bytes,
}


def run_all_decoders(data: bytes) -> None:
    """Every decoder on ``data`` (the EPL/EtherCAT ones on the bytes after the EtherType)."""
    for name, decode in DECODERS.items():
        arg = data[14:] if name.startswith(("powerlink", "ethercat")) else data
        try:
            decode(arg)
        except DecodeError:
            pass
        except Exception as exc:
            raise AssertionError(f"{name} raised {type(exc).__name__}: {exc}") from exc


@FUZZ
@given(any_bytes)
def test_random_bytes_raise_only_decode_errors(data: bytes) -> None:
    run_all_decoders(data)
    run_all_decoders(bytes(14) + data)  # the protocol decoders on the random bytes themselves


@FUZZ
@given(st.one_of(structured, mutated_frames()))
def test_structured_bytes_raise_only_decode_errors(data: bytes) -> None:
    run_all_decoders(data)


@FUZZ
@given(fuzz_frames)
def test_capture_mode_keeps_every_byte(data: bytes) -> None:
    frame = decode_frame(data)  # never raises for 14 bytes or more
    assert frame.to_bytes() == data
    assert decode_frame(frame.to_bytes()) == frame


@given(st.binary(max_size=13))
def test_shorter_than_a_header_is_truncated(data: bytes) -> None:
    with pytest.raises(TruncatedError):
        decode_frame(data)


@FUZZ
@given(fuzz_frames)
def test_what_strict_mode_accepts_re_encodes_exactly(data: bytes) -> None:
    try:
        frame = decode_frame(data, strict=True)
    except DecodeError:
        return
    assert frame.to_bytes() == data
    assert decode_frame(data) == frame  # capture mode agrees on a conforming frame


@FUZZ
@given(st.one_of(structured, mutated_frames()))
def test_capture_mode_records_what_strict_mode_rejects(data: bytes) -> None:
    # EPL/EtherCAT frames only: other EtherTypes are counted as "other", not reported
    if data[12:14] not in (b"\x88\xab", b"\x88\xa4"):
        return
    try:
        decode_frame(data, strict=True)
    except DecodeError:
        assert decode_frame(data).findings, "strict mode rejected it, capture mode saw nothing"


# --- captures -----------------------------------------------------------------------------------------
@st.composite
def pcap_files(draw: st.DrawFn) -> bytes:
    """A valid pcap (sometimes big-endian or microsecond), then damaged."""
    records = draw(st.lists(st.tuples(st.integers(0, 2**40), st.binary(max_size=80)), max_size=5))
    raw = bytearray(pcap_bytes(records))
    if draw(st.booleans()):  # microsecond magic: fractions must then stay below 1_000_000
        raw[0:4] = struct.pack("<I", 0xA1B2C3D4)
    for _ in range(draw(st.integers(0, 3))):
        op = draw(st.sampled_from(["set", "cut", "append"]))
        if op == "set" and raw:
            raw[draw(st.integers(0, len(raw) - 1))] = draw(u8)
        elif op == "cut":
            raw = raw[: draw(st.integers(0, len(raw)))]
        else:
            raw += draw(st.binary(max_size=40))
    return bytes(raw)


captures = st.one_of(
    pcap_files(),
    pcap_files().map(gzip.compress),
    pcap_files().map(lambda b: gzip.compress(b)[: len(b) // 2]),
    st.binary(max_size=200).map(lambda b: b"\x0a\x0d\x0d\x0a" + b),
    st.binary(max_size=200).map(lambda b: b"\x0a\x0d\x0d\x0a" + struct.pack("<I", 28) + b),
    st.binary(max_size=200).map(lambda b: b"\x1f\x8b" + b),
    st.binary(max_size=200).map(lambda b: struct.pack(">I", 0xA1B23C4D) + b),
)


@FUZZ
@given(captures)
def test_damaged_captures_raise_only_pcap_format_errors(raw: bytes) -> None:
    try:
        capture = parse_capture(raw)
    except PcapFormatError:
        return
    assert capture.total == len(capture.records) + len(capture.skipped)
    for rec in capture.records:
        assert rec.orig_len >= len(rec.data)
