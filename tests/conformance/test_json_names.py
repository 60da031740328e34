"""``decode --json`` keys named after Wireshark's fields carry tshark's values.

The EPL flag bits (``fls``, ``sls``, ``en``, ...) and the SDO pad size (``sdo_data_padding``)
are compared with tshark's ``epl.*`` fields of those names, frame by frame, on the real EPL
captures, on the conformance vectors and on frames packed here by hand (struct, per DS 301).
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import pytest
import tshark_util

from skinframes import golden, powerlink, read_capture, vectors
from skinframes.describe import record_json
from skinframes.pcap import write_pcap

pytestmark = pytest.mark.tshark

PCAPS = Path(__file__).resolve().parents[2] / "pcaps"

# decode --json: (message or service name, key) -> tshark field of that name
_BITS: dict[str, dict[str, str]] = {
    "SOC": {k: f"epl.soc.{k}" for k in ("mc", "ps", "an")},
    "PREQ": {k: f"epl.preq.{k}" for k in ("ms", "ea", "rd", "fls", "sls")},
    "PRES": {k: f"epl.pres.{k}" for k in ("ms", "en", "rd", "fls", "sls", "pr", "rs")},
    "SOA": {k: f"epl.soa.{k}" for k in ("ea", "er")},
    "AINV": {k: f"epl.soa.{k}" for k in ("ea", "er")},  # the SoA's layout (DS 302-A)
    "IDENT_RESPONSE": {k: f"epl.asnd.ires.{k}" for k in ("en", "ec", "fls", "sls", "pr", "rs")},
    "STATUS_RESPONSE": {k: f"epl.asnd.sres.{k}" for k in ("en", "ec", "fls", "sls", "pr", "rs")},
}
PADDING = "epl.asnd.sdo.cmd.data.padding"
FIELDS = [f for table in _BITS.values() for f in table.values()] + [PADDING]

_ASND_MAC = bytes.fromhex("01111e000004")
_CN_MAC = bytes.fromhex("020000000005")


def _ours(obj: dict[str, Any]) -> dict[str, list[int]]:
    """Our JSON object's Wireshark-named keys as tshark field -> occurrences."""
    out: dict[str, list[int]] = {f: [] for f in FIELDS}
    owner = obj.get("service") if obj.get("message") == "ASND" else obj.get("message")
    for key, name in _BITS.get(str(owner), {}).items():
        out[name] = [int(obj[key])]
    out[PADDING] = list(obj.get("sdo_data_padding", []))
    return out


def assert_names_agree(tshark: str, path: Path) -> int:
    """Every frame we decode as EPL: our keys equal tshark's fields (absent where tshark shows
    none); returns the number of frames where some such field is present."""
    rows = tshark_util.fields(tshark, path, FIELDS)
    records = list(read_capture(path))
    assert len(rows) == len(records)
    shown = 0
    for rec, row in zip(records, rows, strict=True):
        theirs = {k: [int(v, 0) for v in vs] for k, vs in row.items()}
        obj = record_json(rec)
        if obj["protocol"] != "epl":  # kept as bytes (an undecodable EPL frame): no EPL keys
            continue
        assert _ours(obj) == theirs, f"frame {rec.frame}"
        shown += any(theirs.values())
    return shown


def _sdo(sequence: int, command_id: int, response: bool, segmentation: int, data: bytes) -> bytes:
    """An ASnd SDO frame packed by hand: Ethernet, ASnd header (DS 301 4.6.1.1.6), sequence
    layer (6.3.2.3.1: receive 0, send ``sequence``, both con 2: valid; Wireshark skips the
    command layer of a frame repeating the previous sequence numbers), command layer
    (6.3.2.4.1), zero padding."""
    flags = (0x80 if response else 0) | segmentation << 4
    command = struct.pack("<BBBBHH", 0, 7, flags, command_id, len(data), 0) + data
    epl = bytes([6, 240, 5, 5]) + bytes([0x02, sequence << 2 | 0x02, 0, 0]) + command
    frame = _ASND_MAC + _CN_MAC + b"\x88\xab" + epl
    return frame.ljust(60, b"\x00")


def _entry(next_offset: int, index: int, sub: int, bits: int, data: bytes) -> bytes:
    return struct.pack("<IHBB", next_offset, index, sub, bits) + data


def _crafted() -> list[bytes]:
    frames = []
    for f1, f2 in ((0, 0), (0xFF, 0xFF), (0x80, 0x40), (0x10, 0x2D), (0x24, 0x93)):
        frames.append(powerlink.frame(powerlink.SoC(flags=f1)).to_bytes())
        frames.append(powerlink.frame(powerlink.PReq(3, b"ab", flags1=f1, flags2=f2)).to_bytes())
        frames.append(powerlink.frame(powerlink.PRes(3, b"ab", flags1=f1, flags2=f2)).to_bytes())
        frames.append(powerlink.frame(powerlink.SoA(flags1=f1)).to_bytes())
        for service in (
            powerlink.IdentResponse(flags1=f1, flags2=f2),
            powerlink.StatusResponse(flags1=f1, flags2=f2),
        ):
            frames.append(powerlink.frame(powerlink.ASnd(service, src=3)).to_bytes())
    # WriteMultipleParam requests: offsets count from the command layer's first byte (+8)
    two = _entry(8 + 12, 0x6000, 1, 0x03, b"\x11\x00\x00\x00") + _entry(0, 0x6000, 2, 0, b"\x22")
    frames.append(_sdo(1, 0x31, False, 0, two))
    # an expedited one with a 3-byte entry (pad 1) between two others, 16 + 8 + 12 + 8 bytes
    three = (
        _entry(8 + 16, 0x6001, 1, 0x02, b"abcdef\x00\x00")
        + _entry(8 + 24, 0x6001, 2, 0x01, b"xyz\x00")
        + _entry(8 + 36, 0x6001, 3, 0x00, b"1234")
        + _entry(0, 0x6001, 4, 0x80, b"\x11\x00\x09\x06")
    )
    frames.append(_sdo(2, 0x31, False, 0, three))
    frames.append(_sdo(3, 0x32, True, 0, two))  # ReadMultipleParam response: the same layout
    frames.append(_sdo(4, 0x31, True, 0, bytes(8)))  # response: no entries with data
    frames.append(_sdo(5, 0x31, False, 2, two))  # a later segment: no entry headers
    frames.append(
        _sdo(
            6,
            0x31,
            False,
            0,
            _entry(8 + 10, 0x6000, 1, 0x03, b"\x11\x00") + _entry(0, 1, 1, 0, b"\x01"),
        )
    )  # pad + 8 >= length
    frames.append(
        _sdo(7, 0x31, False, 0, _entry(8 + 40, 0x6000, 1, 0x01, b"\x11\x00\x00\x00"))
    )  # past the segment
    frames.append(
        _sdo(8, 0x31, False, 0, _entry(4, 0x6000, 1, 0x02, b"\x11\x00\x00\x00") + bytes(8))
    )  # backwards
    return frames


def test_crafted_frames(tshark: str, tmp_path: Path) -> None:
    path = tmp_path / "names.pcap"
    write_pcap(path, [(i * 1000, raw) for i, raw in enumerate(_crafted())])
    assert assert_names_agree(tshark, path) > 0


@pytest.mark.parametrize(
    "name",
    ["epl-viz_EPL_Example.cap", "epl-viz_1CN.pcapng", "epl-viz_MultiWriteRead_example.pcapng"],
)
def test_real_epl_captures(tshark: str, shared_captures: Path, name: str) -> None:
    assert assert_names_agree(tshark, shared_captures / name) > 0


def test_vectors_and_golden(tshark: str, tmp_path: Path) -> None:
    vectors.write(tmp_path)
    assert assert_names_agree(tshark, tmp_path / vectors.PCAP_NAME) > 0
    for name in sorted(golden.SCENARIOS):
        if name.startswith("epl"):
            assert assert_names_agree(tshark, PCAPS / f"{name}.pcap") > 0
