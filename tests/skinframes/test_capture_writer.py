"""CaptureWriter: the bytes against the capture specifications, tshark's reading, atomic replacement.

The expected files are built here with ``struct`` from the specifications, never with the code
under test:

- pcap (draft-ietf-opsawg-pcap 4-5): header ``magic 0xA1B23C4D, 2, 4, 0, 0, snaplen, linktype``,
  record header ``sec, nsec, incl_len, orig_len``, little endian.
- pcapng (draft-ietf-opsawg-pcapng 4.1-4.3): blocks ``type, total_length, body, total_length``;
  options ``code u16, length u16, value padded to 4``; if_name 2, if_tsresol 9, opt_comment 1,
  epb_flags 2 (bits 0-1 direction: 01 inbound, 10 outbound; bit 24 CRC error).

tshark 4.0.17 is the second judge: it must read every file without a warning and report the
stamps, interfaces, directions and comments written.
"""

from __future__ import annotations

import os
import stat
import struct
import tempfile
from decimal import Decimal
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
import tshark_util
from hypothesis import given
from hypothesis import strategies as st

from skinframes import capture_writer, powerlink
from skinframes.errors import CaptureError, FieldRangeError, FrameTooLargeError, SkinframesError
from skinframes.pcap import CaptureWriter, read_capture

NS = 1_000_000_000
PCAP_MAX_NS = (2**32 - 1) * NS + NS - 1  # u32 seconds, nanoseconds 0..999999999


# --- the expected bytes, from the specifications ---------------------------------------------------
def pcap_file(records: list[tuple[int, bytes]]) -> bytes:
    out = struct.pack("<IHHiIII", 0xA1B23C4D, 2, 4, 0, 0, 65535, 1)
    for t, data in records:
        out += struct.pack("<IIII", t // NS, t % NS, len(data), len(data)) + data
    return out


def ng_option(code: int, value: bytes) -> bytes:
    return struct.pack("<HH", code, len(value)) + value + bytes(-len(value) % 4)


def ng_block(btype: int, body: bytes) -> bytes:
    body += bytes(-len(body) % 4)
    return struct.pack("<II", btype, 12 + len(body)) + body + struct.pack("<I", 12 + len(body))


def ng_file(
    names: list[str], records: list[tuple[int, int, bytes, int | None, str | None]]
) -> bytes:
    """SHB, one IDB per name (if_name, if_tsresol 9), one EPB per (iface, t, data, flags, comment)."""
    end = struct.pack("<HH", 0, 0)
    out = ng_block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1) + end)
    for name in names:
        opts = ng_option(2, name.encode()) + ng_option(9, b"\x09") + end
        out += ng_block(1, struct.pack("<HHI", 1, 0, 65535) + opts)
    for iface, t, data, flags, comment in records:
        body = struct.pack("<IIIII", iface, t >> 32, t & 0xFFFFFFFF, len(data), len(data))
        body += data + bytes(-len(data) % 4)
        opts = b""
        if comment is not None:
            opts += ng_option(1, comment.encode())
        if flags is not None:
            opts += ng_option(2, struct.pack("<I", flags))
        out += ng_block(6, body + (opts + end if opts else b""))
    return out


def pres(node: int, size: int) -> bytes:
    """A valid EPL PRes frame of 14 + 10 + size bytes (at least 60), payload bytes = node."""
    return powerlink.frame(powerlink.PRes(node, bytes([node]) * size)).to_bytes()


# --- bytes -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("behind", [False, True], ids=["direct", "write-behind"])
def test_pcap_bytes_equal_the_specification(tmp_path: Path, behind: bool) -> None:
    records = [(1_700_000_000_123_456_789, pres(1, 36)), (0, pres(2, 100)), (PCAP_MAX_NS, b"\x01")]
    path = tmp_path / "x.pcap"
    with CaptureWriter(path, write_behind=behind) as w:
        for t, data in records:
            w.write(t, data, port=0, outbound=True)  # direction: not representable, not written
        assert w.records == 3
    raw = path.read_bytes()
    assert raw == pcap_file(records)
    assert raw[:24] == bytes.fromhex("4d3cb2a1 0200 0400 00000000 00000000 ffff0000 01000000")
    assert raw[24:40] == bytes.fromhex("00f15365 15cd5b07 3c000000 3c000000")  # 1700000000 s ...
    assert w.bytes_written == len(raw)


@pytest.mark.parametrize("behind", [False, True], ids=["direct", "write-behind"])
def test_pcapng_bytes_equal_the_specification(tmp_path: Path, behind: bool) -> None:
    path = tmp_path / "x.pcapng"
    a, b = pres(3, 37), pres(4, 1490)  # 61 bytes: 3 of padding; 1514
    with CaptureWriter(path, ports=2, port_names=["master", "ring end"], write_behind=behind) as w:
        w.write(5, a)
        w.write((1 << 32) + 7, b, port=1, outbound=True)
        w.write(9, a, port=1, outbound=False, crc_error=True, comment="bit 9 flipped")
        w.write(10, a, crc_error=True)
    raw = path.read_bytes()
    assert raw == ng_file(
        ["master", "ring end"],
        [
            (0, 5, a, None, None),
            (1, (1 << 32) + 7, b, 0x2, None),
            (1, 9, a, 0x1 | 1 << 24, "bit 9 flipped"),
            (0, 10, a, 1 << 24, None),
        ],
    )
    assert w.bytes_written == len(raw)


def test_default_port_names(tmp_path: Path) -> None:
    path = tmp_path / "x.pcapng"
    with CaptureWriter(path, ports=3):
        pass
    assert path.read_bytes() == ng_file(["port 0", "port 1", "port 2"], [])


@pytest.mark.parametrize(
    ("name", "fmt", "expected"),
    [
        ("a.pcapng", None, "pcapng"),
        ("a.PCAPNG", None, "pcapng"),
        ("a.pcap", None, "pcap"),
        ("a.cap", None, "pcap"),
        ("a", None, "pcap"),
        ("a.pcap", "pcapng", "pcapng"),
        ("a.pcapng", "pcap", "pcap"),
    ],
)
def test_format_from_suffix_or_argument(
    tmp_path: Path, name: str, fmt: str | None, expected: str
) -> None:
    with CaptureWriter(tmp_path / name, fmt=fmt) as w:
        assert w.fmt == expected
    magic = (tmp_path / name).read_bytes()[:4]
    assert magic == (b"\x0a\x0d\x0d\x0a" if expected == "pcapng" else b"\x4d\x3c\xb2\xa1")


# --- write_block == write, record by record --------------------------------------------------------
@st.composite
def blocks(draw: st.DrawFn) -> tuple[str, int, np.ndarray, np.ndarray, np.ndarray, object, object]:
    fmt = draw(st.sampled_from(["pcap", "pcapng"]))
    k = draw(st.integers(0, 7))
    r = draw(st.integers(0, 6))
    n_ports = draw(st.integers(1, 3))
    # lengths all multiples of 4 put every pcap stamp on a 4-byte boundary (stamped as u32 words)
    align = draw(st.sampled_from([1, 4]))
    size = st.integers(0, 70).map(lambda n: n * align)
    lengths = np.array(draw(st.lists(size, min_size=r, max_size=r)), np.int64)
    limit = PCAP_MAX_NS if fmt == "pcap" else 2**63 - 1
    stamp = st.one_of(st.integers(0, 10**6), st.integers(0, limit), st.just(limit))
    times = np.array(draw(st.lists(stamp, min_size=k * r, max_size=k * r)), np.int64)
    raw = draw(st.binary(min_size=k * int(lengths.sum()), max_size=k * int(lengths.sum())))
    data = np.frombuffer(raw, np.uint8).reshape(k, int(lengths.sum()))
    ports = draw(st.none() | st.lists(st.integers(0, n_ports - 1), min_size=r, max_size=r))
    outbound = draw(st.none() | st.lists(st.booleans(), min_size=r, max_size=r))
    return fmt, n_ports, times.reshape(k, r), lengths, data, ports, outbound


@given(blocks(), st.integers(1, 3), st.sampled_from([1, 150, 1000, None]), st.booleans())
def test_write_block_equals_write_one_by_one(
    block: tuple[str, int, np.ndarray, np.ndarray, np.ndarray, object, object],
    repeat: int,
    chunk_bytes: int | None,
    behind: bool,
) -> None:
    # chunk_bytes: the size of write_block's reused image (None: the default), so that blocks
    # are written in chunks of 1, a few, or all of their rows; behind: the chunks go to the
    # writer's thread while the image is refilled (WriteBehind copies them)
    fmt, n_ports, times, lengths, data, ports, outbound = block
    k, r = times.shape
    port_arr = None if ports is None else np.array(ports, dtype=np.int32)
    out_arr = None if outbound is None else np.array(outbound, dtype=bool)
    with tempfile.TemporaryDirectory() as tmp:
        one, many = Path(tmp) / "one", Path(tmp) / "many"
        with CaptureWriter(one, fmt=fmt, ports=n_ports) as w1:
            for _ in range(repeat):  # the second block reuses the cached layout
                for c in range(k):
                    start = 0
                    for j in range(r):
                        n = int(lengths[j])
                        w1.write(
                            int(times[c, j]),
                            data[c, start : start + n].tobytes(),
                            port=0 if port_arr is None else int(port_arr[j]),
                            outbound=None if out_arr is None else bool(out_arr[j]),
                        )
                        start += n
        chunk = capture_writer._CHUNK_BYTES if chunk_bytes is None else chunk_bytes
        with (
            mock.patch.object(capture_writer, "_CHUNK_BYTES", chunk),
            CaptureWriter(many, fmt=fmt, ports=n_ports, write_behind=behind) as w2,
        ):
            for _ in range(repeat):
                w2.write_block(times, lengths, data, ports=port_arr, outbound=out_arr)
        assert w2.records == w1.records == repeat * k * r
        assert w2.bytes_written == w1.bytes_written == many.stat().st_size
        assert many.read_bytes() == one.read_bytes()


def test_write_block_then_another_layout(tmp_path: Path) -> None:
    # blocks of different layouts and single records interleave in call order
    frames = [pres(i, 30 + 50 * i) for i in range(1, 5)]
    expected = [(0, frames[0]), (1, frames[1]), (2, frames[0]), (3, frames[1])]
    expected += [(10, frames[2]), (20, frames[3]), (30, frames[2])]
    with CaptureWriter(tmp_path / "x.pcap") as w:
        lens = np.array([len(frames[0]), len(frames[1])])
        row = np.frombuffer(frames[0] + frames[1], np.uint8)
        w.write_block(np.array([[0, 1], [2, 3]]), lens, np.stack([row, row]))
        w.write_block(
            np.array([[10]]), np.array([len(frames[2])]), np.frombuffer(frames[2], np.uint8)[None]
        )
        w.write(20, frames[3])
        w.write_block(
            np.array([[30]]), np.array([len(frames[2])]), np.frombuffer(frames[2], np.uint8)[None]
        )
    assert (tmp_path / "x.pcap").read_bytes() == pcap_file(expected)


# --- tshark and our reader -------------------------------------------------------------------------
def mixed_records() -> list[tuple[int, bytes, int, bool | None, bool, str | None]]:
    """(time_ns, frame, port, outbound, crc_error, comment) of a two-port capture."""
    stamps = [0, 1, 999_999_999, NS, 1_700_000_000 * NS + 123_456_789, PCAP_MAX_NS]
    out = []
    for i, t in enumerate(stamps):
        out.append(
            (
                t,
                pres(i + 1, [36, 1, 100, 1490, 37, 500][i]),
                i % 2,
                [True, False, None][i % 3],
                False,
                None,
            )
        )
    out[3] = (*out[3][:4], True, "CRC broken on link 2")
    out[4] = (*out[4][:5], "a comment: ünicode")
    return out


@pytest.mark.tshark
def test_tshark_reads_the_pcapng(tshark: str, tmp_path: Path) -> None:
    path = tmp_path / "mixed.pcapng"
    records = mixed_records()
    with CaptureWriter(path, ports=2, port_names=["master out", "master in"]) as w:
        for t, frame, port, outbound, crc, comment in records:
            w.write(t, frame, port=port, outbound=outbound, crc_error=crc, comment=comment)
    assert tshark_util.problems(tshark, path) == []
    assert "Frame 6:" in tshark_util.run(tshark, path, "-V")
    names = [
        "frame.time_epoch",
        "frame.interface_id",
        "frame.interface_name",
        "frame.p2p_dir",
        "frame.packet_flags_crc_error",
        "frame.comment",
        "frame.cap_len",
        "epl.src",
    ]
    rows = tshark_util.fields(tshark, path, names)
    assert len(rows) == len(records)
    for row, (t, frame, port, outbound, crc, comment) in zip(rows, records, strict=True):
        assert int(Decimal(row["frame.time_epoch"][0]) * NS) == t
        assert row["frame.interface_id"] == [str(port)]
        assert row["frame.interface_name"] == [["master out", "master in"][port]]
        # p2p_dir: 0 sent (outbound), 1 received (inbound); absent without a direction
        assert row["frame.p2p_dir"] == ([] if outbound is None else ["0" if outbound else "1"])
        assert row["frame.packet_flags_crc_error"] == (
            ["1"] if crc else [] if outbound is None else ["0"]
        )
        assert row["frame.comment"] == ([] if comment is None else [comment])
        assert row["frame.cap_len"] == [str(len(frame))]
        assert row["epl.src"] == [str(frame[16])]


@pytest.mark.tshark
def test_tshark_reads_the_pcap_and_a_block(tshark: str, tmp_path: Path) -> None:
    path = tmp_path / "block.pcap"
    lengths = np.array([60, 61, 124, 1514])
    frames = [pres(i + 1, int(n) - 24 if n > 60 else 36) for i, n in enumerate(lengths)]
    k = 50
    data = np.tile(np.frombuffer(b"".join(frames), np.uint8), (k, 1))
    times = 1_000_000 * np.arange(k)[:, None] + np.array([0, 6_000, 12_000, 30_000])
    with CaptureWriter(path) as w:
        w.write_block(times, lengths, data, outbound=np.array([True, False, False, True]))
    assert tshark_util.problems(tshark, path) == []
    rows = tshark_util.fields(tshark, path, ["frame.time_epoch", "frame.cap_len", "epl.src"])
    assert [int(Decimal(r["frame.time_epoch"][0]) * NS) for r in rows] == times.ravel().tolist()
    assert [int(r["frame.cap_len"][0]) for r in rows] == lengths.tolist() * k
    assert [int(r["epl.src"][0]) for r in rows] == [1, 2, 3, 4] * k


@pytest.mark.tshark
@pytest.mark.parametrize("name", ["cut.pcap", "cut.pcapng"])
def test_a_cut_frame_keeps_its_original_length(tshark: str, tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    frame = pres(1, 36)
    with CaptureWriter(path) as w:
        w.write(0, frame[:30], orig_len=len(frame))  # the first 30 bytes of a 60-byte frame
        w.write(1, frame, orig_len=None)
        for bad in (29, 2**32):
            with pytest.raises(FieldRangeError):
                w.write(2, frame[:30], orig_len=bad)
    rows = tshark_util.run(tshark, path, "-T", "fields", "-e", "frame.len", "-e", "frame.cap_len")
    assert rows.split() == ["60", "30", "60", "60"]
    assert [r.orig_len for r in read_capture(path)] == [60, 60]


def test_read_capture_reads_everything_back(tmp_path: Path) -> None:
    records = mixed_records()
    path = tmp_path / "mixed.pcapng"
    with CaptureWriter(path, ports=2) as w:
        for t, frame, port, outbound, crc, comment in records:
            w.write(t, frame, port=port, outbound=outbound, crc_error=crc, comment=comment)
    capture = read_capture(path)
    assert capture.skipped == ()
    assert [(r.time_ns, r.data, r.interface, r.comments) for r in capture] == [
        (t, frame, port, () if comment is None else (comment,))
        for t, frame, port, _, _, comment in records
    ]
    plain = tmp_path / "plain.pcap"
    with CaptureWriter(plain, ports=2) as w:  # ports are checked, not written
        for t, frame, port, *_ in records:
            w.write(t, frame, port=port)
    assert [(r.time_ns, r.data, r.interface) for r in read_capture(plain)] == [
        (t, frame, 0) for t, frame, *_ in records
    ]


# --- what classic pcap cannot hold, and ranges ------------------------------------------------------
@pytest.mark.parametrize("mark", [{"crc_error": True}, {"comment": "x"}, {"comment": ""}])
def test_classic_pcap_refuses_marks(tmp_path: Path, mark: dict[str, object]) -> None:
    with CaptureWriter(tmp_path / "x.pcap") as w, pytest.raises(CaptureError, match=r"\.pcapng"):
        w.write(0, pres(1, 36), **mark)  # type: ignore[arg-type]


def test_timestamp_ranges(tmp_path: Path) -> None:
    frame = pres(1, 36)
    with CaptureWriter(tmp_path / "x.pcap") as w:
        w.write(PCAP_MAX_NS, frame)
        for bad in (-1, PCAP_MAX_NS + 1):
            with pytest.raises(FieldRangeError):
                w.write(bad, frame)
            with pytest.raises(FieldRangeError):
                w.write_block(np.array([[0], [bad]]), np.array([60]), np.zeros((2, 60), np.uint8))
        assert w.records == 1
    with CaptureWriter(tmp_path / "x.pcapng") as w:
        w.write(2**64 - 1, frame)
        w.write_block(np.array([[2**63 - 1]]), np.array([60]), np.zeros((1, 60), np.uint8))
        for bad in (-1, 2**64):
            with pytest.raises(FieldRangeError):
                w.write(bad, frame)
        with pytest.raises(FieldRangeError):
            w.write_block(np.array([[-1]]), np.array([60]), np.zeros((1, 60), np.uint8))
    assert [r.time_ns for r in read_capture(tmp_path / "x.pcapng")] == [2**64 - 1, 2**63 - 1]


def test_bad_arguments(tmp_path: Path) -> None:
    frame = pres(1, 36)
    with pytest.raises(CaptureError):
        CaptureWriter(tmp_path / "x.pcap", fmt="erf")
    with pytest.raises(CaptureError):
        CaptureWriter(tmp_path / "x.pcapng", ports=2, port_names=["only one"])
    with pytest.raises(CaptureError):
        CaptureWriter(tmp_path / "x.pcapng", ports=0)
    assert list(tmp_path.iterdir()) == []
    with CaptureWriter(tmp_path / "x.pcapng", ports=2) as w:
        with pytest.raises(FieldRangeError):
            w.write(0, frame, port=2)
        with pytest.raises(FrameTooLargeError):
            w.write(0, bytes(65536))
        ok = (np.zeros((2, 3), np.int64), np.array([60, 0, 1]), np.zeros((2, 61), np.uint8))
        with pytest.raises(CaptureError):
            w.write_block(ok[0], ok[1], np.zeros((2, 60), np.uint8))
        with pytest.raises(CaptureError):
            w.write_block(ok[0], ok[1][:2], ok[2])
        with pytest.raises(CaptureError):
            w.write_block(ok[0][0], ok[1], ok[2])
        with pytest.raises(TypeError):
            w.write_block(ok[0], ok[1], ok[2].astype(np.int16))  # type: ignore[arg-type]
        with pytest.raises(TypeError):
            w.write_block(ok[0].astype(float), ok[1], ok[2])  # type: ignore[arg-type]
        with pytest.raises(TypeError):
            w.write_block(*ok, outbound=np.array([1, 0, 1]))  # type: ignore[arg-type]
        with pytest.raises(FieldRangeError):
            w.write_block(*ok, ports=np.array([0, 2, 1]))
        with pytest.raises(FrameTooLargeError):
            w.write_block(ok[0], np.array([60, 0, -1]), ok[2])
        assert w.records == 0
    with pytest.raises(CaptureError, match="closed"):
        w.write(0, frame)
    w.close()  # a second close does nothing
    assert read_capture(tmp_path / "x.pcapng").total == 0


# --- atomic replacement and refused paths ----------------------------------------------------------
class BoomError(Exception):
    pass


@pytest.mark.parametrize("error", [BoomError, KeyboardInterrupt])
@pytest.mark.parametrize("name", ["x.pcap", "x.pcapng"])
@pytest.mark.parametrize("behind", [False, True], ids=["direct", "write-behind"])
def test_exception_keeps_the_previous_file(
    tmp_path: Path, error: type[BaseException], name: str, behind: bool
) -> None:
    path = tmp_path / name
    path.write_bytes(b"the previous capture")
    with pytest.raises(error), CaptureWriter(path, write_behind=behind) as w:
        w.write(0, pres(1, 36))
        w.write_block(np.zeros((3, 1), np.int64), np.array([60]), np.zeros((3, 60), np.uint8))
        assert [p.name for p in tmp_path.iterdir() if p != path] != []  # the temporary file
        raise error()
    assert path.read_bytes() == b"the previous capture"
    assert list(tmp_path.iterdir()) == [path]


@pytest.mark.parametrize("behind", [False, True], ids=["direct", "write-behind"])
def test_success_replaces_the_previous_file_and_only_then(tmp_path: Path, behind: bool) -> None:
    path = tmp_path / "x.pcap"
    path.write_bytes(b"old")
    with CaptureWriter(path, write_behind=behind) as w:
        w.write(0, pres(1, 36))
        assert path.read_bytes() == b"old"  # not yet
        (tmp,) = (p for p in tmp_path.iterdir() if p != path)
        assert tmp.name.startswith(".x.pcap.") and tmp.name.endswith(".tmp")
    assert path.read_bytes() == pcap_file([(0, pres(1, 36))])
    assert list(tmp_path.iterdir()) == [path]


@pytest.mark.parametrize("behind", [False, True], ids=["direct", "write-behind"])
def test_unclosed_writer_leaves_nothing(tmp_path: Path, behind: bool) -> None:
    w = CaptureWriter(tmp_path / "x.pcap", write_behind=behind)
    w.write(0, pres(1, 36))
    del w
    assert list(tmp_path.iterdir()) == []


def test_new_file_mode_is_that_of_a_plain_open(tmp_path: Path) -> None:
    plain = tmp_path / "plain"
    plain.write_bytes(b"")  # open(path, "w"): 0o666 minus the umask
    with CaptureWriter(tmp_path / "x.pcap"):
        pass
    mode = stat.S_IMODE((tmp_path / "x.pcap").stat().st_mode)
    assert mode == stat.S_IMODE(plain.stat().st_mode)
    old = os.umask(0o077)
    try:
        with CaptureWriter(tmp_path / "y.pcap"):
            pass
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "y.pcap").stat().st_mode) == 0o600


def test_refused_paths(tmp_path: Path) -> None:
    target = tmp_path / "real.pcap"
    target.write_bytes(b"keep me")
    link = tmp_path / "link.pcap"
    link.symlink_to(target)
    dangling = tmp_path / "dangling.pcap"
    dangling.symlink_to(tmp_path / "nowhere.pcap")
    (tmp_path / "dir.pcap").mkdir()
    before = sorted(tmp_path.iterdir())
    for path, why in (
        (link, "symbolic link"),
        (dangling, "symbolic link"),
        (tmp_path / "dir.pcap", "directory"),
        (tmp_path / "missing" / "x.pcap", "does not exist"),
        (target / "x.pcap", "real.pcap is not a directory"),  # a file where a folder should be
    ):
        with pytest.raises(CaptureError, match=why):
            CaptureWriter(path)
        with pytest.raises(SkinframesError):
            CaptureWriter(str(path), fmt="pcapng")
    assert sorted(tmp_path.iterdir()) == before
    assert target.read_bytes() == b"keep me"
    assert not (tmp_path / "nowhere.pcap").exists()
    assert not (tmp_path / "missing").exists()


def test_a_compressed_name_is_refused_not_written_plain(tmp_path: Path) -> None:
    """x.pcapng.gz once got a classic pcap, uncompressed: neither what the name says."""
    for name in ("x.pcap.gz", "x.pcapng.GZ", "x.pcapng.zst", "x.pcap.xz"):
        with pytest.raises(CaptureError, match=f"{name}: captures are written uncompressed"):
            CaptureWriter(tmp_path / name)
    assert list(tmp_path.iterdir()) == []
    assert capture_writer.capture_format("a.PCAPNG") == "pcapng"
    assert capture_writer.capture_format("a.cap") == "pcap"


# --- write_repeated == write, record by record ------------------------------------------------------
@given(st.data(), st.sampled_from([1, 150, None]))
def test_write_repeated_equals_write_one_by_one(
    data: st.DataObject, chunk_bytes: int | None
) -> None:
    # a template row, some fills inside frames, and calls that alternate with write_block and
    # change the fills: every row must be the template with that call's fills, nothing stale
    fmt = data.draw(st.sampled_from(["pcap", "pcapng"]))
    lengths = np.array(data.draw(st.lists(st.integers(1, 40), min_size=1, max_size=4)), np.int64)
    total = int(lengths.sum())
    starts = np.concatenate(([0], np.cumsum(lengths)))[:-1]
    template = np.frombuffer(data.draw(st.binary(min_size=total, max_size=total)), np.uint8)
    chunk = capture_writer._CHUNK_BYTES if chunk_bytes is None else chunk_bytes
    expected: list[tuple[int, bytes]] = []
    with tempfile.TemporaryDirectory() as tmp:
        one, many = Path(tmp) / "one", Path(tmp) / "many"
        with (
            mock.patch.object(capture_writer, "_CHUNK_BYTES", chunk),
            CaptureWriter(many, fmt=fmt) as w,
        ):
            t = 0
            for call in range(data.draw(st.integers(1, 4))):
                k = data.draw(st.integers(0, 5))
                fills = []
                rows = np.tile(template, (k, 1))
                for _ in range(data.draw(st.integers(0, 3))):
                    j = data.draw(st.integers(0, len(lengths) - 1))
                    lo = data.draw(st.integers(0, int(lengths[j]) - 1))
                    n = data.draw(st.integers(1, int(lengths[j]) - lo))
                    raw = data.draw(st.binary(min_size=k * n, max_size=k * n))
                    values = np.frombuffer(raw, np.uint8).reshape(k, n)
                    fills.append((int(starts[j]) + lo, values))
                    rows[:, int(starts[j]) + lo : int(starts[j]) + lo + n] = values
                times = t + np.arange(k * len(lengths), dtype=np.int64).reshape(k, len(lengths))
                t += k * len(lengths)
                if call % 2 and data.draw(st.booleans()):
                    w.write_block(times, lengths, rows)
                else:
                    w.write_repeated(times, lengths, template, fills=fills)
                for c in range(k):
                    for j, n in enumerate(lengths.tolist()):
                        lo = int(starts[j])
                        expected.append((int(times[c, j]), rows[c, lo : lo + n].tobytes()))
        with CaptureWriter(one, fmt=fmt) as w1:
            for time_ns, frame in expected:
                w1.write(time_ns, frame)
        assert many.read_bytes() == one.read_bytes()


@given(st.data())
def test_write_repeated_joins_strided_fills_and_keeps_their_order(data: st.DataObject) -> None:
    # fills that are one (k, m, bytes) array's columns, equally spaced in the frames (across
    # frames of one length, as an EPL cycle's PRes, or inside one frame, as an LRD per slave),
    # are written with one strided copy: the bytes must be those of the fills one by one, and a
    # fill after them that overlaps them must still win
    fmt = data.draw(st.sampled_from(["pcap", "pcapng"]))
    length = data.draw(st.integers(4, 40))
    frames = data.draw(st.integers(1, 5))
    lengths = np.array([length] * frames + data.draw(st.lists(st.integers(1, 9), max_size=1)))
    starts = np.concatenate(([0], np.cumsum(lengths)))[:-1]
    total = int(lengths.sum())
    template = np.frombuffer(data.draw(st.binary(min_size=total, max_size=total)), np.uint8)
    k = data.draw(st.integers(1, 4))
    base = np.frombuffer(data.draw(st.binary(min_size=k * 8 * 12, max_size=k * 8 * 12)), np.uint8)
    base = base.reshape(k, 8, 12)
    n = data.draw(st.integers(1, min(length, 10)))
    lo, col = data.draw(st.integers(0, length - n)), data.draw(st.integers(0, 12 - n))
    if data.draw(st.booleans()):  # one fill per frame of that length
        fills = [(int(starts[j]) + lo, base[:, j, col : col + n]) for j in range(frames)]
    else:  # m fills inside the first frame, step bytes apart
        step = data.draw(st.integers(n, max(n, length - lo - n)))
        m = min(8, (length - lo - n) // step + 1)
        fills = [(lo + p * step, base[:, p, col : col + n]) for p in range(m)]
    if data.draw(st.booleans()):  # a lone fill over the first of them, last
        fills.append((fills[0][0], np.full((k, 1), 0xEE, np.uint8)))
    rows = np.tile(template, (k, 1))
    for at, values in fills:
        rows[:, at : at + values.shape[1]] = values
    times = np.arange(k * len(lengths), dtype=np.int64).reshape(k, len(lengths))
    with tempfile.TemporaryDirectory() as tmp:
        one, many = Path(tmp) / "one", Path(tmp) / "many"
        with CaptureWriter(many, fmt=fmt) as w:
            w.write_repeated(times, lengths, template, fills=fills)
        with CaptureWriter(one, fmt=fmt) as w1:
            for c in range(k):
                for j, size in enumerate(lengths.tolist()):
                    w1.write(int(times[c, j]), rows[c, starts[j] : starts[j] + size].tobytes())
        assert many.read_bytes() == one.read_bytes()


def test_fills_of_one_array_equally_spaced_are_one_copy() -> None:
    # the image columns and the (k, nodes, bytes) taxels of an EPL cycle: 3 PRes 100 bytes apart
    taxels = np.arange(2 * 3 * 4, dtype=np.uint8).reshape(2, 3, 4)
    places = [(10 + 100 * j, taxels[:, j, :]) for j in range(3)]
    ((at, step, values),) = capture_writer._runs_of(places, 2)
    assert (at, step, values.shape) == (10, 100, (2, 3, 4))
    assert np.array_equal(values, taxels)
    # not equally spaced, or overlapping: one by one
    uneven = [places[0], places[1], (205, taxels[:, 2, :])]
    assert [s for _, s, _ in capture_writer._runs_of(uneven, 2)] == [100, 0]
    overlapping = [(10 + 2 * j, taxels[:, j, :]) for j in range(3)]
    assert [s for _, s, _ in capture_writer._runs_of(overlapping, 2)] == [0, 0, 0]
    # equally spaced in the image but not in memory, or of other widths: one by one
    back = [places[0], places[1], (210, taxels[:, 0, :])]
    assert [s for _, s, _ in capture_writer._runs_of(back, 2)] == [100, 0]
    widths = [places[0], (110, taxels[:, 1, :3]), (210, taxels[:, 2, :])]
    assert [s for _, s, _ in capture_writer._runs_of(widths, 2)] == [0, 0, 0]


def test_a_fill_must_stay_inside_one_frame(tmp_path: Path) -> None:
    with CaptureWriter(tmp_path / "x.pcap") as w:
        lengths = np.array([60, 60])
        template = np.zeros(120, np.uint8)
        with pytest.raises(CaptureError, match="not inside one frame"):
            w.write_repeated(
                np.array([[0, 1]]), lengths, template, fills=[(58, np.ones((1, 4), np.uint8))]
            )
        with pytest.raises(CaptureError, match="template of shape"):
            w.write_repeated(np.array([[0, 1]]), lengths, template[:100])
