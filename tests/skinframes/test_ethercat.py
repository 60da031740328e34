"""EtherCAT codec properties: round trips, the struct/numpy fast paths against the construct
schemas, strict rejections, out-of-range values, and the frame-layout arithmetic (paper eq. 15)."""

from __future__ import annotations

import itertools
import math
import struct

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skinframes import decode_frame, ethercat
from skinframes.errors import (
    EncodeError,
    FieldRangeError,
    FrameTooLargeError,
    InvalidFieldError,
    LengthMismatchError,
    TruncatedError,
)
from skinframes.ethercat import Command, Datagram, EcatFrame

u8 = st.integers(0, 0xFF)
u16 = st.integers(0, 0xFFFF)
u32 = st.integers(0, 0xFFFFFFFF)
MAX_BODY = 1500 - 2  # datagram bytes that fit one frame after the 2-byte header


@st.composite
def datagram_lists(draw: st.DrawFn, max_datagrams: int = 24) -> list[Datagram]:
    """1..n datagrams of every command whose frame fits 1500 bytes."""
    budget = MAX_BODY
    out: list[Datagram] = []
    count = draw(st.integers(1, max_datagrams))
    big = draw(st.booleans())  # sometimes let one datagram take most of the frame
    while len(out) < count and budget >= 12:
        limit = budget - 12 if big else min(budget - 12, 64)
        n = draw(st.integers(0, limit))
        out.append(
            Datagram(
                cmd=draw(st.sampled_from(Command)),
                adp=draw(u16),
                ado=draw(u16),
                data=draw(st.binary(min_size=n, max_size=n)),
                idx=draw(u8),
                irq=draw(u16),
                wkc=draw(u16),
                circulating=draw(st.booleans()),
            )
        )
        budget -= 12 + n
    return out


ecat_frames = datagram_lists().map(lambda ds: EcatFrame(tuple(ds)))
single_datagrams = datagram_lists(max_datagrams=1).map(lambda ds: ds[0])


def schema_dict(d: Datagram, more: bool) -> dict[str, object]:
    return {
        "cmd": d.cmd,
        "idx": d.idx,
        "adp": d.adp,
        "ado": d.ado,
        "flags": {"more": more, "circulating": d.circulating, "reserved": d.reserved},
        "irq": d.irq,
        "data": d.data,
        "wkc": d.wkc,
    }


# --- round trips -----------------------------------------------------------------------------------
@given(ecat_frames, st.booleans())
def test_round_trip(ecat: EcatFrame, returned: bool) -> None:
    frame = ethercat.frame(ecat, returned=returned)
    data = frame.to_bytes()
    decoded = decode_frame(data, strict=True)
    assert decoded == frame
    assert decoded.payload == ecat
    assert decoded.findings == ()
    assert decoded.to_bytes() == data
    assert decode_frame(data) == frame


@given(ecat_frames)
def test_decode_reports_the_frame_length(ecat: EcatFrame) -> None:
    body = ecat.to_bytes()
    decoded, used, findings = ethercat.decode(body + bytes(max(0, 46 - len(body))))
    assert decoded == ecat
    assert used == len(body) == 2 + ecat.datagram_bytes
    assert findings == []


@given(ecat_frames)
def test_frame_layout(ecat: EcatFrame) -> None:
    # frames.md 2.1/2.2, written from the table: header 0x1000 | length, then per datagram
    # cmd idx adp ado len|C|M irq data wkc
    b = ecat.to_bytes()
    assert int.from_bytes(b[:2], "little") == 0x1000 | ecat.datagram_bytes
    pos = 2
    for i, d in enumerate(ecat.datagrams):
        more = i < len(ecat.datagrams) - 1
        word = len(d.data) | (0x4000 if d.circulating else 0) | (0x8000 if more else 0)
        assert b[pos] == d.cmd
        assert b[pos + 1] == d.idx
        assert int.from_bytes(b[pos + 2 : pos + 4], "little") == d.adp
        assert int.from_bytes(b[pos + 4 : pos + 6], "little") == d.ado
        assert int.from_bytes(b[pos + 6 : pos + 8], "little") == word
        assert int.from_bytes(b[pos + 8 : pos + 10], "little") == d.irq
        assert b[pos + 10 : pos + 10 + len(d.data)] == d.data
        pos += 10 + len(d.data)
        assert int.from_bytes(b[pos : pos + 2], "little") == d.wkc
        pos += 2
    assert pos == len(b)


@given(st.sampled_from(sorted(ethercat.LOGICAL_COMMANDS)), u32, st.binary(max_size=16))
def test_logical_address(cmd: Command, lad: int, data: bytes) -> None:
    d = Datagram.logical(cmd, lad, data, wkc=1)
    assert d.lad == lad
    assert d.to_bytes()[2:6] == lad.to_bytes(4, "little")  # ecat.lad: one LE u32


def test_returned_mac() -> None:
    # frames.md 0: an ESC sets bit 0x02 of the first source-MAC octet
    assert ethercat.returned_mac(bytes.fromhex("101010101010")) == bytes.fromhex("121010101010")
    assert ethercat.returned_mac(bytes.fromhex("010101010101")) == bytes.fromhex("030101010101")
    assert ethercat.returned_mac(bytes(6)) == bytes.fromhex("020000000000")
    frame = ethercat.frame(EcatFrame((Datagram(Command.BRD, 0, 0x130, bytes(2)),)), returned=True)
    assert frame.src == bytes.fromhex("02005e005301")
    assert frame.dst == b"\xff" * 6
    assert frame.ethertype == 0x88A4


def test_command_values() -> None:
    # frames.md 2.2, Wireshark's EcCmdShort
    assert {c.name: int(c) for c in Command} == {
        "NOP": 0, "APRD": 1, "APWR": 2, "APRW": 3, "FPRD": 4, "FPWR": 5, "FPRW": 6, "BRD": 7,
        "BWR": 8, "BRW": 9, "LRD": 10, "LWR": 11, "LRW": 12, "ARMW": 13, "FRMW": 14, "EXT": 255,
    }  # fmt: skip


# --- fast path (struct) == schema of record (construct) -------------------------------------------
@given(single_datagrams, st.booleans(), st.integers(0, 7))
def test_datagram_to_bytes_equals_schema(d: Datagram, more: bool, reserved: int) -> None:
    d = Datagram(d.cmd, d.adp, d.ado, d.data, d.idx, d.irq, d.wkc, d.circulating, reserved=reserved)
    assert d.to_bytes(more=more) == ethercat.datagram_schema.build(schema_dict(d, more))


@given(ecat_frames)
def test_frame_to_bytes_equals_schema(ecat: EcatFrame) -> None:
    last = len(ecat.datagrams) - 1
    built = ethercat.frame_schema.build(
        {
            "header": {
                "type": 1,
                "reserved": False,
                "length": sum(12 + len(d.data) for d in ecat.datagrams),
            },
            "datagrams": [schema_dict(d, i < last) for i, d in enumerate(ecat.datagrams)],
        }
    )
    assert ecat.to_bytes() == built


@st.composite
def capture_frames(draw: st.DrawFn) -> bytes:
    """EtherCAT bytes with the deviations capture mode keeps: reserved bits, any command byte."""
    ds = draw(datagram_lists(max_datagrams=8))
    parts = []
    for i, d in enumerate(ds):
        cmd = draw(st.one_of(st.just(int(d.cmd)), u8))
        reserved = draw(st.integers(0, 7))
        more = i < len(ds) - 1
        parts.append(
            Datagram(cmd, d.adp, d.ado, d.data, d.idx, d.irq, d.wkc, d.circulating, more, reserved)
        )
    header_reserved = draw(st.booleans())
    return EcatFrame(tuple(parts), reserved=header_reserved).to_bytes()


@given(capture_frames())
def test_decode_agrees_with_schema_parse(body: bytes) -> None:
    fast, used, _ = ethercat.decode(body, strict=False)
    slow = ethercat.frame_schema.parse(body)  # GreedyRange: no padding after the body here
    assert used == len(body)
    assert fast.frame_type == slow.header.type
    assert fast.reserved == slow.header.reserved
    assert fast.length is None
    assert slow.header.length == fast.datagram_bytes
    assert len(fast.datagrams) == len(slow.datagrams)
    last = len(fast.datagrams) - 1
    for i, (d, c) in enumerate(zip(fast.datagrams, slow.datagrams, strict=True)):
        assert (d.cmd, d.idx, d.adp, d.ado, d.irq, d.wkc) == (
            c.cmd,
            c.idx,
            c.adp,
            c.ado,
            c.irq,
            c.wkc,
        )
        assert d.data == c.data
        assert d.length == c.flags.length
        assert d.circulating == c.flags.circulating
        assert d.reserved == c.flags.reserved
        assert c.flags.more == (i < last)
        assert d.more is None  # the M bits match the positions
    assert fast.to_bytes() == ethercat.frame_schema.build(slow)


# --- strict mode rejects what capture mode records ------------------------------------------------
def _frame_bytes(datagrams: tuple[Datagram, ...], **kwargs: object) -> bytes:
    return ethercat.frame(EcatFrame(datagrams, **kwargs)).to_bytes()  # type: ignore[arg-type]


LRD = Datagram(Command.LRD, 0, 1, bytes(4), wkc=1)


@pytest.mark.parametrize(
    ("data", "error", "code"),
    [
        (_frame_bytes((LRD,), reserved=True), InvalidFieldError, "ecat.header.reserved"),
        (_frame_bytes((LRD,), length=100), LengthMismatchError, "ecat.header.length"),
        (
            _frame_bytes((Datagram(Command.LRD, 0, 1, bytes(4), reserved=2),)),
            InvalidFieldError,
            "ecat.datagram.reserved",
        ),
        (_frame_bytes((Datagram(0x42, 0, 0, bytes(4)),)), InvalidFieldError, "ecat.cmd.unknown"),
        (
            _frame_bytes((Datagram(Command.LRD, 0, 1, bytes(4), more=True),)),
            InvalidFieldError,
            "ecat.more.last",
        ),
    ],
)
def test_strict_errors_are_capture_findings(data: bytes, error: type, code: str) -> None:
    with pytest.raises(error):
        decode_frame(data, strict=True)
    decoded = decode_frame(data)
    assert isinstance(decoded.payload, EcatFrame)
    assert code in [f.code for f in decoded.findings]
    assert decoded.to_bytes() == data


def test_frames_longer_than_an_ethernet_payload_are_not_decoded() -> None:
    # two 800-byte datagrams: 2 + 2 x 812 = 1626 bytes after the EtherType (a jumbo frame)
    dg = [struct.pack("<BBHHHH", 0x0C, i, 0, 0, 800 | (0x8000 if i == 0 else 0), 0) for i in (0, 1)]
    body = struct.pack("<H", 0x1000 | 1624) + b"".join(d + bytes(802) for d in dg)
    raw = ethercat.BROADCAST_MAC + ethercat.MASTER_MAC + b"\x88\xa4" + body
    with pytest.raises(LengthMismatchError):
        decode_frame(raw, strict=True)
    frame = decode_frame(raw)
    assert isinstance(frame.payload, bytes)
    assert "ecat.undecodable" in [f.code for f in frame.findings]
    assert frame.to_bytes() == raw


RESERVED_TYPES = [t for t in range(16) if t not in (1, 4, 5)]


@given(st.sampled_from(RESERVED_TYPES), st.binary(max_size=40))
def test_reserved_frame_types_are_kept_with_a_warning(frame_type: int, rest: bytes) -> None:
    body = (len(rest) | frame_type << 12).to_bytes(2, "little") + rest
    with pytest.raises(InvalidFieldError):
        ethercat.decode(body, strict=True)
    frame, used, findings = ethercat.decode(body, strict=False)
    assert [(f.code, str(f.severity)) for f in findings] == [("ecat.type.reserved", "warning")]
    assert (frame.content, frame.frame_type, used) == (rest, frame_type, len(body))
    assert frame.to_bytes() == body
    raw = ethercat.frame(frame).to_bytes()
    assert decode_frame(raw).to_bytes() == raw


nv_variables = st.builds(
    ethercat.NetworkVariable, u16, st.binary(max_size=40), hash=u16, quality=u16
)
nv_publications = st.builds(
    ethercat.NvPublication,
    st.binary(min_size=6, max_size=6),
    st.lists(nv_variables, max_size=5).map(tuple),
    cycle_index=u16,
)
mailboxes = st.builds(
    ethercat.Mailbox,
    u16,
    st.integers(0, 15),
    st.binary(max_size=100),
    channel=st.integers(0, 63),
    priority=st.integers(0, 3),
    counter=st.integers(0, 7),
    reserved=st.booleans(),
)


@given(nv_publications)
def test_network_variables_round_trip_and_equal_the_schema(nv: ethercat.NvPublication) -> None:
    ecat = EcatFrame((), ethercat.FrameType.NV, content=nv)
    body = ecat.to_bytes()
    parsed = ethercat.nv_header_schema.parse(body[2:])
    assert (parsed.publisher, parsed.count, parsed.cycle_index) == (
        nv.publisher,
        len(nv.variables),
        nv.cycle_index,
    )
    at = 2 + ethercat.NV_HEADER_BYTES
    for v in nv.variables:
        got = ethercat.nv_variable_schema.parse(body[at:])
        assert (got.id, got.hash, got.quality, got.data) == (v.id, v.hash, v.quality, v.data)
        assert ethercat.nv_variable_schema.build(got) == v.to_bytes()
        at += len(v.to_bytes())
    assert ethercat.frame_header_schema.parse(body[:2]).length == len(body) - 2
    decoded, used, findings = ethercat.decode(body + bytes(7), strict=True)
    assert (decoded, used, findings) == (ecat, len(body), [])


@given(mailboxes)
def test_mailbox_round_trips_and_equals_the_schema(mbx: ethercat.Mailbox) -> None:
    ecat = EcatFrame((), ethercat.FrameType.MAILBOX, content=mbx)
    body = ecat.to_bytes()
    head = ethercat.mailbox_header_schema.parse(body[2:])
    assert (head.length, head.address) == (len(mbx.data), mbx.address)
    c = head.control
    assert (c.type, c.channel, c.priority, c.counter, c.reserved) == (
        mbx.mailbox_type,
        mbx.channel,
        mbx.priority,
        mbx.counter,
        mbx.reserved,
    )
    assert ethercat.mailbox_header_schema.build(head) == body[2:8]
    decoded, used, findings = ethercat.decode(body, strict=True)
    assert (decoded, used, findings) == (ecat, len(body), [])


def test_mailbox_longer_than_the_frame_is_undecodable() -> None:
    body = ethercat.EcatFrame(
        (), ethercat.FrameType.MAILBOX, content=ethercat.Mailbox(0x1001, 3, bytes(10))
    ).to_bytes()
    with pytest.raises(TruncatedError):
        ethercat.decode(body[:-1], strict=False)


def _chain(*words: int, header_length: int, tail: bytes = b"") -> bytes:
    """An EtherCAT body of FPRD datagrams with 4 data bytes and the given length|M words."""
    parts = [struct.pack("<H", header_length | 0x1000)]
    for i, word in enumerate(words):
        parts.append(struct.pack("<BBHHHH", 4, i, 0x1001 + i, 0x130, word, 0) + bytes(6))
    return b"".join(parts) + tail


@pytest.mark.parametrize(
    ("body", "idx", "code"),
    [
        # M clear on the first of two: Wireshark shows one datagram, the length says two
        (_chain(4, 4, header_length=32), [0], "ecat.header.length"),
        # M set on the last, zero padding follows: Wireshark reads a NOP from the padding
        (_chain(0x8004, 0x8004, header_length=32, tail=bytes(20)), [0, 1, 0], "ecat.more.last"),
        # the length says one datagram, the M bits chain two
        (_chain(0x8004, 4, header_length=16), [0, 1], "ecat.more.last"),
        # the length says three, the M bits chain two
        (_chain(0x8004, 4, header_length=48, tail=bytes(20)), [0, 1], "ecat.header.length"),
        # M set on the last, 5 bytes follow: too short for a datagram (Wireshark: malformed)
        (_chain(0x8004, 0x8004, header_length=32, tail=bytes(5)), [0, 1], "ecat.more.truncated"),
    ],
)
def test_the_m_bit_chain_is_followed_like_wireshark(body: bytes, idx: list[int], code: str) -> None:
    """Which datagrams Wireshark 4.0 shows for these bodies was read off tshark (see
    tests/conformance/test_encapsulation.py, which asks tshark the same for every case)."""
    frame, _, findings = ethercat.decode(body, strict=False)
    assert [d.idx for d in frame.datagrams] == idx
    assert [f.code for f in findings] == [code]
    assert str(findings[0].severity) in ("warning", "error")
    raw = ethercat.frame(frame).to_bytes()
    eth = raw[:14] + body
    assert decode_frame(eth).to_bytes() == eth
    with pytest.raises((InvalidFieldError, LengthMismatchError, TruncatedError)):
        ethercat.decode(body, strict=True)


@given(ecat_frames, st.data())
def test_truncated_datagrams_raise(ecat: EcatFrame, data: st.DataObject) -> None:
    body = ecat.to_bytes()
    cut = data.draw(st.integers(0, len(body) - 1))
    ends = list(itertools.accumulate((d.size_bytes for d in ecat.datagrams), initial=2))
    if cut < 2 or cut not in ends:
        error: type[Exception] = TruncatedError  # inside the header or a datagram
    elif cut == 2:
        error = LengthMismatchError  # no datagram left, the header length says otherwise
    else:
        error = InvalidFieldError  # the M bit is set on what is now the last datagram
    with pytest.raises(error):
        ethercat.decode(body[:cut], strict=True)


# --- out-of-range values ---------------------------------------------------------------------------
@given(st.integers(2048, 3000))
def test_11_bit_length_overflow(n: int) -> None:
    with pytest.raises(FieldRangeError):
        Datagram(Command.LWR, 0, 0, bytes(n)).to_bytes()


@given(st.integers(2048, 0xFFFF))
def test_header_length_overflow(length: int) -> None:
    with pytest.raises(FieldRangeError):
        EcatFrame((LRD,), length=length).to_bytes()


@given(st.integers(16, 255))
def test_frame_type_overflow(frame_type: int) -> None:
    with pytest.raises(FieldRangeError):
        EcatFrame((LRD,), frame_type=frame_type).to_bytes()


@given(st.lists(st.integers(0, 1486), min_size=1, max_size=8))
def test_frames_over_1500_bytes_are_too_large(sizes: list[int]) -> None:
    ecat = EcatFrame(tuple(Datagram(Command.LRW, 0, 0, bytes(n)) for n in sizes))
    if 2 + sum(12 + n for n in sizes) > 1500:
        with pytest.raises(FrameTooLargeError):
            ecat.to_bytes()
        with pytest.raises(FrameTooLargeError):
            ethercat.frame(ecat).to_bytes()
    else:
        assert len(ecat.to_bytes()) == 2 + sum(12 + n for n in sizes)


def test_largest_datagram() -> None:
    assert ethercat.MAX_DATAGRAM_DATA_BYTES == 1486  # SOEM EC_MAXLRWDATA (frames.md 2.2)
    one = EcatFrame((Datagram(Command.LRW, 0, 0, bytes(1486)),))
    assert len(ethercat.frame(one).to_bytes()) == 1514
    with pytest.raises(FrameTooLargeError):
        EcatFrame((Datagram(Command.LRW, 0, 0, bytes(1487)),)).to_bytes()


@pytest.mark.parametrize(
    "make",
    [
        lambda: Datagram(256, 0, 0),
        lambda: Datagram(-1, 0, 0),
        lambda: Datagram(Command.APRD, 0x10000, 0),
        lambda: Datagram(Command.APRD, 0, -1),
        lambda: Datagram(Command.APRD, 0, 0, idx=256),
        lambda: Datagram(Command.APRD, 0, 0, irq=0x10000),
        lambda: Datagram(Command.APRD, 0, 0, wkc=0x10000),
        lambda: Datagram(Command.APRD, 0, 0, reserved=8),
    ],
)
def test_datagram_fields_out_of_range(make: object) -> None:
    with pytest.raises(FieldRangeError):
        make().to_bytes()  # type: ignore[operator]
    with pytest.raises(FieldRangeError):
        EcatFrame((make(),)).to_bytes()  # type: ignore[operator]


@pytest.mark.parametrize("lad", [-1, 2**32])
def test_logical_address_out_of_range(lad: int) -> None:
    with pytest.raises(FieldRangeError):
        Datagram.logical(Command.LRD, lad, b"")


def test_wrong_types_stay_type_errors() -> None:
    with pytest.raises(TypeError):
        Datagram(Command.LRD, 0, 0, None).to_bytes()  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        ethercat.pack_frames_batch([1], [0], np.zeros((2, 1, 4), dtype=np.int64))
    with pytest.raises(TypeError):
        ethercat.pack_frames_batch([1], [0], np.zeros((2, 4), dtype=np.uint8))  # not (n, k, B)


# --- layout arithmetic (paper eqs. 14-15), hand-computed -----------------------------------------
@pytest.mark.parametrize(
    ("data_bytes", "per_frame"),
    [
        (192, 7),  # floor(1498 / 204)
        (2, 107),  # floor(1498 / 14)
        (0, 124),  # floor(1498 / 12)
        (32, 34),  # floor(1498 / 44)
        (128, 10),  # floor(1498 / 140)
        (256, 5),  # floor(1498 / 268)
        (1486, 1),
    ],
)
def test_datagrams_per_frame(data_bytes: int, per_frame: int) -> None:
    assert ethercat.datagrams_per_frame(data_bytes) == per_frame


@pytest.mark.parametrize(
    ("datagrams", "data_bytes", "frames"),
    [(160, 192, 23), (7, 192, 1), (8, 192, 2), (160, 2, 2), (107, 2, 1), (1, 1486, 1), (0, 2, 0)],
)
def test_frames_needed(datagrams: int, data_bytes: int, frames: int) -> None:
    assert ethercat.frames_needed(datagrams, data_bytes) == frames


@given(st.integers(0, 1486))
def test_datagrams_per_frame_is_the_most_that_fit(data_bytes: int) -> None:
    n = ethercat.datagrams_per_frame(data_bytes)
    assert 2 + n * (12 + data_bytes) <= 1500 < 2 + (n + 1) * (12 + data_bytes)


@pytest.mark.parametrize("data_bytes", [-1, 1487])
def test_datagrams_per_frame_out_of_range(data_bytes: int) -> None:
    with pytest.raises(FieldRangeError):
        ethercat.datagrams_per_frame(data_bytes)


@given(st.integers(0, 300), st.integers(0, 1486))
def test_pack_datagrams_of_equal_size(count: int, data_bytes: int) -> None:
    ds = [Datagram(Command.LRD, i & 0xFFFF, 0, bytes(data_bytes)) for i in range(count)]
    frames = ethercat.pack_datagrams(ds)
    assert len(frames) == math.ceil(count / ethercat.datagrams_per_frame(data_bytes))
    assert len(frames) == ethercat.frames_needed(count, data_bytes)
    assert [d for f in frames for d in f.datagrams] == ds
    assert all(len(f.to_bytes()) <= 1500 for f in frames)


@given(datagram_lists(max_datagrams=60), st.integers(100, 1500))
def test_pack_datagrams_fills_each_frame(ds: list[Datagram], limit: int) -> None:
    if any(2 + d.size_bytes > limit for d in ds):
        with pytest.raises(FrameTooLargeError):
            ethercat.pack_datagrams(ds, limit)
        return
    frames = ethercat.pack_datagrams(ds, limit)
    assert [d for f in frames for d in f.datagrams] == ds
    for f, nxt in itertools.pairwise(frames):
        assert len(f.to_bytes()) <= limit
        assert len(f.to_bytes()) + nxt.datagrams[0].size_bytes > limit  # greedy: next did not fit


# --- numpy batch path == per-frame encoding --------------------------------------------------------
@st.composite
def batches(draw: st.DrawFn) -> dict[str, object]:
    k = draw(st.integers(1, 8))
    size = draw(st.integers(0, min(200, (MAX_BODY // k) - 12)))
    n = draw(st.integers(0, 5))
    raw = draw(st.binary(min_size=n * k * size, max_size=n * k * size))
    return {
        "cmds": draw(st.lists(st.sampled_from(Command), min_size=k, max_size=k)),
        "addresses": np.array(
            draw(st.lists(st.lists(u32, min_size=k, max_size=k), min_size=n, max_size=n)),
            dtype=np.int64,
        ).reshape(n, k),
        "data": np.frombuffer(raw, dtype=np.uint8).reshape(n, k, size),
        "idx": np.array(draw(st.lists(u8, min_size=k, max_size=k)), dtype=np.int64),
        "wkc": draw(u16),
        "src": draw(st.binary(min_size=6, max_size=6)),
    }


@given(batches())
def test_pack_frames_batch_equals_per_frame_encoding(b: dict[str, object]) -> None:
    cmds, addresses, data = b["cmds"], b["addresses"], b["data"]
    assert isinstance(cmds, list)
    assert isinstance(addresses, np.ndarray)
    assert isinstance(data, np.ndarray)
    idx, wkc, src = b["idx"], b["wkc"], b["src"]
    assert isinstance(idx, np.ndarray)
    assert isinstance(wkc, int)
    assert isinstance(src, bytes)
    out = ethercat.pack_frames_batch(cmds, addresses, data, idx=idx, wkc=wkc, src=src)
    n, k, size = data.shape
    assert out.shape == (n, max(14 + 2 + k * (12 + size), 60))
    for i in range(n):
        ecat = EcatFrame(
            tuple(
                Datagram(
                    cmds[j],
                    int(addresses[i, j]) & 0xFFFF,
                    int(addresses[i, j]) >> 16,
                    data[i, j].tobytes(),
                    idx=int(idx[j]),
                    wkc=wkc,
                )
                for j in range(k)
            )
        )
        assert out[i].tobytes() == ethercat.frame(ecat, src=src).to_bytes()
    got_cmds, got_addr, got_data, got_wkc = ethercat.unpack_frames_batch(out, k, size)
    assert got_cmds.tolist() == [list(map(int, cmds))] * n
    assert np.array_equal(got_addr, addresses)
    assert np.array_equal(got_data, data)
    assert np.array_equal(got_wkc, np.full((n, k), wkc))
    assert not got_data.flags.writeable


def test_unpack_frames_batch_rejects_other_layouts() -> None:
    out = ethercat.pack_frames_batch([Command.LRD] * 3, [0, 4, 8], np.zeros((2, 3, 4), np.uint8))
    with pytest.raises(LengthMismatchError):
        ethercat.unpack_frames_batch(out, 3, 3)
    with pytest.raises(LengthMismatchError):
        ethercat.unpack_frames_batch(out, 2, 4)
    bad = out.copy()
    bad[1, 13] = 0xAB  # EPL, not EtherCAT
    with pytest.raises(LengthMismatchError):
        ethercat.unpack_frames_batch(bad, 3, 4)
    with pytest.raises(TruncatedError):
        ethercat.unpack_frames_batch(out[:, :30], 3, 4)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"addresses": [2**32]},
        {"addresses": [-1]},
        {"idx": 256},
        {"idx": -1},
        {"wkc": 0x10000},
        {"wkc": -1},
        {"cmds": [256]},
        {"cmds": [-1]},
        {"cmds": [1, 2]},  # two commands for one datagram
        {"src": bytes(5)},
        {"dst": bytes(7)},
        {"data": np.zeros((1, 1, 1487), np.uint8)},  # 1501-byte frame
        {"data": np.zeros((1, 0, 4), np.uint8), "cmds": [], "addresses": []},  # no datagram
    ],
)
def test_pack_frames_batch_out_of_range(kwargs: dict[str, object]) -> None:
    args: dict[str, object] = {
        "cmds": [Command.LRD],
        "addresses": [0],
        "data": np.zeros((2, 1, 4), np.uint8),
    }
    args.update(kwargs)
    with pytest.raises(EncodeError):
        ethercat.pack_frames_batch(**args)  # type: ignore[arg-type]


def test_datagram_head_reads_the_header_fields_of_etg1000_4_table_12() -> None:
    # LRD (0x0A), index 0x5A, logical address 0x00020010 (ADP 0x0010, ADO 0x0002), 300 bytes with
    # the M bit (0x8000 | 0x012C), IRQ 0x0003, written out byte by byte, little-endian
    head = bytes([0x0A, 0x5A, 0x10, 0x00, 0x02, 0x00, 0x2C, 0x81, 0x03, 0x00])
    assert ethercat.datagram_head(b"\xee" * 5 + head, 5) == (0x0A, 0x5A, 0x10, 2, 0x812C, 3)
