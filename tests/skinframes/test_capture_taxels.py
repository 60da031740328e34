"""taxels_from_capture and the bulk record reader: the taxels the emulator put in come back out,
equal to tshark's payload fields; the record columns equal what skinframes.pcap reads."""

from __future__ import annotations

import gzip
import struct
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
import tshark_util
from encap_util import qinq

from emulator import PAPER, parse_fault, simulate_ecat, simulate_epl
from skinframes import powerlink, taxel, taxels_from_capture
from skinframes.capture_arrays import read_record_arrays
from skinframes.errors import FieldRangeError, PcapFormatError
from skinframes.pcap import read_capture, write_pcap
from skinframes.powerlink import PRes, SoC
from skinframes_cli import main

ROOT = Path(__file__).resolve().parent.parent.parent


def expected(nodes: int, data_bytes: int, cycles: int, seed: int) -> npt.NDArray[np.uint8]:
    """What the emulator carries (taxel.sample_payloads), as (cycles, nodes, 16, 12)."""
    payloads = taxel.sample_payloads(nodes, cycles, data_bytes, seed=seed)
    out = np.zeros((cycles, nodes, taxel.PATCH_BYTES), dtype=np.uint8)
    width = min(data_bytes, taxel.PATCH_BYTES)
    out[:, :, :width] = payloads[:, :, :width]
    return out.reshape(cycles, nodes, 16, 12)


CASES = [
    ("epl", 7, 192, "per-slave", False, "pcap"),
    ("epl", 3, 30, "per-slave", False, "pcapng"),
    ("ecat", 20, 192, "per-slave", False, "pcap"),
    ("ecat", 20, 100, "per-slave", True, "pcapng"),
    ("ecat", 20, 192, "logical", False, "pcap"),
    ("ecat", 9, 192, "logical", True, "pcapng"),
]


def emulate(
    tmp_path: Path, protocol: str, nodes: int, data_bytes: int, layout: str, ring: bool, ext: str
) -> Path:
    path = tmp_path / f"{protocol}_{nodes}x{data_bytes}_{layout}_{ring}.{ext}"
    if protocol == "epl":
        simulate_epl(nodes, data_bytes, PAPER, cycles=5, seed=7, pcap=path)
    else:
        simulate_ecat(
            nodes, data_bytes, PAPER, closed_ring=ring, layout=layout, cycles=5, seed=7, pcap=path
        )
    return path


@pytest.mark.parametrize(("protocol", "nodes", "data_bytes", "layout", "ring", "ext"), CASES)
def test_the_emulated_taxels_come_back(
    tmp_path: Path, protocol: str, nodes: int, data_bytes: int, layout: str, ring: bool, ext: str
) -> None:
    path = emulate(tmp_path, protocol, nodes, data_bytes, layout, ring, ext)
    # a logical image of 192-byte nodes is inferred; other sizes are given
    hint = {} if layout == "per-slave" or data_bytes == 192 else {"bytes_per_node": data_bytes}
    result = taxels_from_capture(path, **hint)  # type: ignore[arg-type]
    assert result.taxels.dtype == np.uint8
    assert np.array_equal(result.taxels, expected(nodes, data_bytes, 5, seed=7))
    assert result.present.all()
    records = read_capture(path).records
    first = records[0].time_ns
    assert result.time_ns[0] == first and np.all(np.diff(result.time_ns) > 0)
    given = taxels_from_capture(path, nodes=nodes, bytes_per_node=data_bytes, layout=layout)
    assert np.array_equal(given.taxels, result.taxels)


def test_gzip_and_the_command_line(tmp_path: Path) -> None:
    path = emulate(tmp_path, "ecat", 5, 192, "per-slave", False, "pcap")
    packed = tmp_path / "c.pcap.gz"
    packed.write_bytes(gzip.compress(path.read_bytes()))
    want = expected(5, 192, 5, seed=7)
    assert np.array_equal(taxels_from_capture(packed).taxels, want)
    assert main(["decode", str(packed), "--taxels", str(tmp_path / "t.npy")]) == 0
    assert np.array_equal(np.load(tmp_path / "t.npy"), want)
    assert main(["decode", str(path), "--taxels", str(tmp_path / "t.npz")]) == 0
    with np.load(tmp_path / "t.npz") as z:
        assert np.array_equal(z["taxels"], want) and z["present"].all()
        assert z["time_ns"].tolist() == taxels_from_capture(path).time_ns.tolist()
    assert main(["decode", str(path), "--taxels", str(tmp_path / "no" / "t.npy")]) == 2


@pytest.mark.parametrize(("protocol", "layout"), [("epl", "per-slave"), ("ecat", "logical")])
def test_taxels_behind_stacked_vlan_tags(tmp_path: Path, protocol: str, layout: str) -> None:
    # the emulated frames behind a hand-typed S-tag and C-tag (encap_util.qinq): the taxels the
    # emulator carried (expected), as from the untagged frames
    plain = emulate(tmp_path, protocol, 4, 192, layout, False, "pcap")
    tagged = qinq(plain, tmp_path / "qinq.pcap")
    result = taxels_from_capture(tagged, nodes=4, bytes_per_node=192, layout=layout)
    assert result.present.all()
    assert np.array_equal(result.taxels, expected(4, 192, 5, seed=7))


def test_a_lost_pres_is_missing_not_invented(tmp_path: Path) -> None:
    path = tmp_path / "power.pcap"
    simulate_epl(4, 192, PAPER, cycles=5, seed=2, faults=(parse_fault("power:3@2"),), pcap=path)
    result = taxels_from_capture(path, nodes=4)
    want = expected(4, 192, 5, seed=2)
    # CN 3 (node index 2) and the CN behind it lose power from cycle 2 on
    assert result.present[:2].all() and not result.present[2:, 2:].any()
    assert result.present[2:, :2].all()
    assert np.array_equal(result.taxels[result.present], want[result.present])
    assert not result.taxels[~result.present].any()


def epl_cycles(path: Path, cycles: list[list[PRes]]) -> Path:
    """A pcap of EPL cycles, each a SoC and the PRes given, 1 ms apart."""
    records = []
    for k, cycle in enumerate(cycles):
        for j, message in enumerate([SoC(), *cycle]):
            records.append((k * 1_000_000 + j * 100_000, powerlink.frame(message).to_bytes()))
    write_pcap(path, records)
    return path


def test_a_pres_without_rd_carries_no_sample(tshark: str, tmp_path: Path) -> None:
    # DS 301 4.6.1.1.4: a PRes's payload is valid only with RD (flags byte 4, bit 0), which a CN
    # sets in NMT_CS_OPERATIONAL; CN 2 still boots in cycle 0 (RD clear, a payload of 0x55s)
    cycles = [
        [PRes(1, b"\x11" * 192), PRes(2, b"\x55" * 192, nmt_status=0x5D, flags1=0)],
        [PRes(1, b"\x12" * 192), PRes(2, b"\x22" * 192)],
    ]
    path = epl_cycles(tmp_path / "boot.pcap", cycles)
    rd = [row["epl.pres.rd"] for row in tshark_util.fields(tshark, path, ["epl.pres.rd"])]
    assert rd == [[], ["1"], ["0"], [], ["1"], ["1"]]  # tshark reads the flag where we do
    result = taxels_from_capture(path, nodes=2, bytes_per_node=192)
    assert result.present.tolist() == [[True, False], [True, True]]
    flat = result.taxels.reshape(2, 2, -1)
    assert (flat[0, 0] == 0x11).all() and not flat[0, 1].any()  # missing reads as zeros
    assert (flat[1, 0] == 0x12).all() and (flat[1, 1] == 0x22).all()


def test_a_pres_shorter_than_the_patch_carries_no_sample(tshark: str, tmp_path: Path) -> None:
    # DS 301 4.6.1.1.4: a PRes's Size field counts its payload octets. CN 2 is OPERATIONAL (RD
    # set) but sends no payload in cycle 0 (a CN whose TPDO mapping is empty) and 100 of its 192
    # bytes in cycle 1: neither carries its patch, which stays missing rather than read as zeros
    cycles = [
        [PRes(1, b"\x11" * 192), PRes(2, b"")],
        [PRes(1, b"\x12" * 192), PRes(2, b"\x22" * 100)],
        [PRes(1, b"\x13" * 192), PRes(2, b"\x23" * 192)],
    ]
    path = epl_cycles(tmp_path / "short.pcap", cycles)
    fields = tshark_util.fields(tshark, path, ["epl.pres.rd", "epl.pres.size"])
    assert [row["epl.pres.rd"] for row in fields] == [[], ["1"], ["1"]] * 3
    sizes = [row["epl.pres.size"] for row in fields]  # tshark reads the size where we do
    assert sizes == [[], ["192"], ["0"], [], ["192"], ["100"], [], ["192"], ["192"]]
    result = taxels_from_capture(path, nodes=2, bytes_per_node=192)
    assert result.present.tolist() == [[True, False], [True, False], [True, True]]
    flat = result.taxels.reshape(3, 2, -1)
    assert not flat[0, 1].any() and not flat[1, 1].any()  # missing reads as zeros
    assert (flat[1, 0] == 0x12).all() and (flat[2, 1] == 0x23).all()


def test_no_skin_data_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(FieldRangeError):
        taxels_from_capture(ROOT / "pcaps" / "ecat_all_commands.pcap", protocol="epl")
    with pytest.raises(FieldRangeError):
        taxels_from_capture(ROOT / "pcaps" / "epl_cycle_4cn.pcap", layout="ring")
    bad = tmp_path / "x.pcap"
    bad.write_bytes(b"not a capture at all")
    with pytest.raises(PcapFormatError):
        taxels_from_capture(bad)
    assert main(["decode", str(bad), "--taxels", str(tmp_path / "t.npy")]) == 2


@pytest.mark.parametrize(("protocol", "nodes", "data_bytes", "layout", "ring", "ext"), CASES)
def test_taxels_equal_tsharks_payload_field(
    tshark: str,
    tmp_path: Path,
    protocol: str,
    nodes: int,
    data_bytes: int,
    layout: str,
    ring: bool,
    ext: str,
) -> None:
    path = emulate(tmp_path, protocol, nodes, data_bytes, layout, ring, ext)
    result = taxels_from_capture(path, bytes_per_node=data_bytes)
    width = min(data_bytes, taxel.PATCH_BYTES)
    image: dict[int, list[bytes]] = {}  # sample -> the payload bytes tshark shows, node order
    if protocol == "epl":
        rows = tshark_util.fields(tshark, path, ["epl.mtyp", "epl.src", "data.data"])
        sample = -1
        for row in rows:
            if row["epl.mtyp"] == ["1"]:
                sample += 1
            elif row["epl.mtyp"] == ["4"]:
                node = int(row["epl.src"][0]) - 1
                got = result.taxels[sample, node].reshape(-1)[:width].tobytes()
                assert got == bytes.fromhex(row["data.data"][0])[:width]
                image.setdefault(sample, []).append(got)
    else:
        rows = tshark_util.fields(tshark, path, ["ecat.cmd", "ecat.lad", "ecat.cnt", "ecat.data"])
        sample = -1
        for row in rows:
            cells = zip(row["ecat.lad"], row["ecat.cnt"], row["ecat.data"], strict=True)
            for lad, wkc, hexdata in cells:
                if int(lad, 0) == 0 and int(wkc, 0) == 0 and (sample < 0 or image.get(sample)):
                    sample += 1
                if int(wkc, 0):
                    image.setdefault(sample, []).append(bytes.fromhex(hexdata))
        for s, parts in image.items():
            flat = b"".join(parts)[: nodes * data_bytes]
            rows_of = np.frombuffer(flat, dtype=np.uint8).reshape(nodes, data_bytes)[:, :width]
            got = result.taxels[s].reshape(nodes, -1)[:, :width]
            assert np.array_equal(got, rows_of)
    assert sorted(image) == list(range(result.taxels.shape[0]))


def _classic(order: str, magic: int, records: list[tuple[int, int, bytes]]) -> bytes:
    out = struct.pack(order + "IHHiIII", magic, 2, 4, 0, 0, 65535, 1)
    for sec, frac, data in records:
        out += struct.pack(order + "IIII", sec, frac, len(data), len(data)) + data
    return out


@pytest.mark.parametrize("order", ["<", ">"])
@pytest.mark.parametrize("magic", [0xA1B2C3D4, 0xA1B23C4D])
def test_record_columns_equal_the_record_reader(tmp_path: Path, order: str, magic: int) -> None:
    rng = np.random.default_rng(1)
    records = [
        (int(rng.integers(0, 2**31)), int(rng.integers(0, 999_999)), rng.bytes(int(n)))
        for n in [60, 60, 216] * 300 + list(rng.integers(14, 1514, size=200))
    ]
    records.insert(500, (1, 2_000_000_000, b"x" * 60))  # a fraction out of range: skipped
    raw = _classic(order, magic, records)
    path = tmp_path / "r.pcap"
    path.write_bytes(raw + b"\x00" * 7)  # a damaged tail
    assert_columns_equal(path)


def assert_columns_equal(path: Path) -> None:
    capture = read_capture(path)
    cols = read_record_arrays(path)
    assert cols.index.tolist() == [r.index for r in capture.records]
    assert cols.time_ns.tolist() == [r.time_ns for r in capture.records]
    assert cols.linktype.tolist() == [r.linktype for r in capture.records]
    for r, at, n in zip(capture.records, cols.offset, cols.length, strict=True):
        assert cols.data[at : at + n].tobytes() == r.data


@pytest.mark.parametrize("name", sorted(p.name for p in (ROOT / "pcaps").glob("*.pcap")))
def test_record_columns_of_the_golden_pcaps(name: str) -> None:
    assert_columns_equal(ROOT / "pcaps" / name)


def test_record_columns_of_the_real_captures(shared_captures: Path) -> None:
    for path in sorted(shared_captures.glob("*.*cap*")):
        assert_columns_equal(path)


def test_record_columns_of_an_emulated_pcapng(tmp_path: Path) -> None:
    assert_columns_equal(emulate(tmp_path, "ecat", 9, 192, "logical", True, "pcapng"))


def test_many_different_pieces_go_byte_by_byte(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from skinframes import capture_taxels

    path = emulate(tmp_path, "ecat", 9, 192, "logical", True, "pcapng")
    rowwise = taxels_from_capture(path)
    monkeypatch.setattr(capture_taxels, "_MAX_PIECES", 0)
    bytewise = taxels_from_capture(path)
    assert np.array_equal(rowwise.taxels, bytewise.taxels)
    assert np.array_equal(rowwise.present, bytewise.present) and bytewise.present.all()
    assert np.array_equal(bytewise.taxels, expected(9, 192, 5, seed=7))


@pytest.mark.parametrize(("protocol", "nodes", "data_bytes", "layout", "ring", "ext"), CASES)
@pytest.mark.parametrize("block", [1, 7, 50])
def test_blocks_of_any_size_give_the_same_samples(
    tmp_path: Path,
    protocol: str,
    nodes: int,
    data_bytes: int,
    layout: str,
    ring: bool,
    ext: str,
    block: int,
) -> None:
    """The capture is read block by block: samples that span blocks, markers at a block's
    edge, and inference over every block give what one block gives (and what went in)."""
    from skinframes.capture_taxels import TaxelStream

    path = emulate(tmp_path, protocol, nodes, data_bytes, layout, ring, ext)
    whole = taxels_from_capture(path)
    stream = TaxelStream(path, block_records=block)
    assert (stream.nodes, stream.layout) == (nodes, layout)
    parts = list(stream.chunks())
    assert len(parts) > 1 or block == 50
    got = [np.concatenate([p[i] for p in parts]) for i in range(3)]
    assert got[0].tobytes() == whole.taxels.tobytes() == expected(nodes, data_bytes, 5, 7).tobytes()
    assert got[1].tolist() == whole.time_ns.tolist()
    assert got[2].tolist() == whole.present.tolist()


def test_a_gzip_capture_is_read_block_by_block_and_a_bomb_refused(tmp_path: Path) -> None:
    """A gzip capture comes from the record reader block by block (two members are one
    capture, as gzip has it); a bomb is its one clear error, not all the memory there is."""
    from skinframes.capture_taxels import TaxelStream

    path = emulate(tmp_path, "ecat", 9, 192, "logical", True, "pcapng")
    raw = path.read_bytes()
    half = len(raw) // 2
    packed = tmp_path / "two.pcapng.gz"
    packed.write_bytes(gzip.compress(raw[:half]) + gzip.compress(raw[half:]))
    parts = list(TaxelStream(packed, block_records=5).chunks())
    assert len(parts) > 1
    got = np.concatenate([p.taxels for p in parts])
    assert got.tobytes() == taxels_from_capture(path).taxels.tobytes()
    bomb = tmp_path / "bomb.pcap.gz"
    header = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 0xFFFF, 1)
    bomb.write_bytes(gzip.compress(header + bytes(16 << 20), 9))
    with pytest.raises(PcapFormatError, match="gzip bomb"):
        taxels_from_capture(bomb)


def test_saved_taxels_hold_a_few_bytes_per_sample_not_the_samples(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """tracemalloc counts what Python and numpy allocate (not time): four times the cycles may
    cost the times and presence (8 + nodes bytes a sample), not the taxels (576 bytes a
    sample here); the file holds them all. (The copy behind the header reads 4 KiB at a time
    here, not its 8 MiB, which would hold these small files whole.)"""
    from memory_util import traced_peak

    from skinframes import capture_taxels
    from skinframes.capture_taxels import TaxelStream, save_taxels

    monkeypatch.setattr(capture_taxels, "_COPY_BYTES", 4096)

    def peak_bytes(cycles: int) -> int:
        path = tmp_path / f"{cycles}.pcap"
        simulate_epl(3, 192, PAPER, cycles=cycles, seed=7, pcap=path)

        def work() -> None:
            done = save_taxels(TaxelStream(path, block_records=64), tmp_path / f"{cycles}.npy")
            assert done.samples == cycles and done.missing == 0

        return traced_peak(work)

    peak_bytes(100)  # warm up: imports, caches
    small, large = 300, 1_200
    growth = peak_bytes(large) - peak_bytes(small)
    assert growth < 64 * (large - small), f"{growth / (large - small):.0f} bytes per sample"
    saved = np.load(tmp_path / f"{large}.npy")
    assert saved.tobytes() == expected(3, 192, large, 7).tobytes()
