"""``skinframes sii``: build from ESI files, decode images, and one error line for bad input."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from skinframes_cli import main

MULTI = b"""<?xml version="1.0"?>
<EtherCATInfo>
  <Vendor><Id>2</Id><Name>Two</Name></Vendor>
  <Descriptions>
    <Devices>
      <Device>
        <Type ProductCode="#x10" RevisionNo="1">A-1</Type><Name>first</Name>
        <Sm StartAddress="#x1000" ControlByte="#x20" Enable="1">Inputs</Sm>
        <Eeprom><ByteSize>256</ByteSize><ConfigData>0500</ConfigData></Eeprom>
      </Device>
      <Device><Type ProductCode="#x20" RevisionNo="2">B-2</Type><Name>second</Name></Device>
      <Device>
        <Type ProductCode="#x10" RevisionNo="#x10001">A-1</Type><Name>first, again</Name>
        <Eeprom><ByteSize>512</ByteSize></Eeprom>
      </Device>
    </Devices>
  </Descriptions>
</EtherCATInfo>
"""


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_build_then_decode_a_shipped_esi(
    shared_esi: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "k2g.bin"
    code, _, err = _run(capsys, "sii", str(shared_esi / "soes_tiesc_k2gice.xml"), "--out", str(out))
    assert code == 0 and "wrote" in err
    shipped = (shared_esi / "soes_tiesc_k2gice.bin").read_bytes()
    assert out.read_bytes()[:0x80] == shipped[:0x80]
    code, text, _ = _run(capsys, "sii", str(shared_esi / "soes_tiesc_k2gice.bin"), "--json")
    doc = json.loads(text)
    assert code == 0
    assert (doc["vendor_id"], doc["product_code"], doc["revision"]) == (0x1337, 0x4291CE, 0)
    assert doc["mailbox_protocols"] == ["coe"] and doc["fmmus"] == [
        "outputs",
        "inputs",
        "syncm_status",
    ]
    assert doc["syncmanagers"][0] == {
        "start": 0x1000,
        "length": 512,
        "control": 0x26,
        "enable": 1,
        "type": "mailbox_out",
    }
    code, text, _ = _run(capsys, "sii", str(out))
    assert code == 0 and "SM3: start 0x1a00" in text and "TxPDO 0x1a00 SM3" in text
    code, text, _ = _run(capsys, "sii", str(out), "--json")
    # the XML: TxPdo #x1A00 on Sm 3, Entry #x6000 SubIndex #x0, BitLen 32, UDINT, "BUTTON"
    assert json.loads(text)["txpdos"][0]["entries"][0] == {
        "index": 0x6000,
        "subindex": 0,
        "bits": 32,
        "data_type": 0x07,
        "name": "BUTTON",
    }


def test_several_devices(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    esi = tmp_path / "multi.xml"
    esi.write_bytes(MULTI)
    out = tmp_path / "a.bin"
    code, _, err = _run(capsys, "sii", str(esi), "--out", str(out))
    assert code == 2 and err.count("\n") == 1 and "A-1" in err and "B-2" in err
    # two revisions of A-1 (product code #x10): Type or product code alone names both
    for selector in ("A-1", "#x10"):
        code, _, err = _run(capsys, "sii", str(esi), "--device", selector, "--out", str(out))
        assert code == 2 and err.count("\n") == 1 and "@REVISION" in err, err
    # ... and @REVISION (RevisionNo, in any notation) one of them: the XML's ByteSize of each
    for selector, size in (("A-1@1", 256), ("#x10@0x10001", 512), ("16@#x10001", 512)):
        code, text, _ = _run(capsys, "sii", str(esi), "--device", selector, "--json")
        assert code == 0 and json.loads(text)["eeprom_bytes"] == size, selector
    code, _, err = _run(capsys, "sii", str(esi), "--device", "A-1@3", "--out", str(out))
    assert code == 2 and "no device 'A-1@3'" in err
    code, _, err = _run(capsys, "sii", str(esi), "--device", "B-2", "--out", str(out))
    assert code == 2 and "B-2 (line 11) has no <Eeprom>" in err  # the Device element's line


def test_a_negative_dc_shift_time(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """ESI's ShiftTimeSync0 is an xs:int (EtherCATInfo.xsd), and an Ingenia drive's ESI gives
    -3 ns: the SII's 32-bit field holds it as its two's complement."""
    esi = tmp_path / "dc.xml"
    esi.write_bytes(
        MULTI.replace(
            b"<Eeprom><ByteSize>256",
            b"<Dc><OpMode><Name>DC</Name><AssignActivate>#x300</AssignActivate>"
            b"<ShiftTimeSync0>-3</ShiftTimeSync0></OpMode></Dc><Eeprom><ByteSize>256",
        )
    )
    code, text, _ = _run(capsys, "sii", str(esi), "--device", "A-1@1", "--json")
    assert code == 0
    (dc,) = json.loads(text)["dc"]
    assert (dc["assign_activate"], dc["shift_time_0_ns"]) == (0x300, 2**32 - 3)


def test_json_of_an_esi(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``sii ESI --json``: the image's document (as decoding the --out file gives it) and
    ``esi``: the Type text, the dictionary's objects (null without one), what was left out,
    and (a device without ``Slots``) no slots and no modules."""
    esi = tmp_path / "multi.xml"
    esi.write_bytes(MULTI)
    out = tmp_path / "a.bin"
    code, text, err = _run(
        capsys, "sii", str(esi), "--device", "A-1@1", "--json", "--out", str(out)
    )
    assert code == 0 and "wrote" in err
    doc = json.loads(text)
    assert doc.pop("esi") == {
        "type": "A-1",
        "objects": None,
        "left_out": [],
        "added_objects": [],  # no CoE
        "slots": None,
        "modules": [],
    }
    assert _run(capsys, "sii", str(out), "--json")[:2] == (0, json.dumps(doc) + "\n")
    assert (doc["product_code"], doc["config_data"]) == (0x10, "0500" + "00" * 12)
    code, _, err = _run(capsys, "sii", str(esi), "--device", "A-1@1", "--json", "--out", "-")
    assert code == 2 and err.count("\n") == 1


def test_bad_input_is_one_error_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "trunc.xml").write_bytes(MULTI[:300])
    (tmp_path / "short.bin").write_bytes(bytes(64))
    (tmp_path / "notsii.txt").write_text("hello\n")
    esi = tmp_path / "m.xml"
    esi.write_bytes(MULTI)
    link = tmp_path / "link.bin"
    link.symlink_to(tmp_path / "target.bin")
    # a DC cycle time is 0..2**32-1 (the SII's field), a shift time an xs:int: both refused
    # outside, with the element's line
    for tag, value, bound in (
        ("CycleTimeSync0", "-1", "0..4294967295"),
        ("ShiftTimeSync0", "2147483648", "-2147483648..2147483647"),
    ):
        (tmp_path / "dc.xml").write_bytes(
            MULTI.replace(
                b"<Eeprom><ByteSize>256",
                f"<Dc><OpMode><Name>DC</Name>\n<{tag}>{value}</{tag}></OpMode></Dc>".encode()
                + b"<Eeprom><ByteSize>256",
            )
        )
        code, _, err = _run(capsys, "sii", str(tmp_path / "dc.xml"), "--device", "A-1@1", "--json")
        assert code == 2 and f"line 10: <{tag}>: {value} ns is outside {bound}" in err, err
    for argv in (
        [str(tmp_path / "trunc.xml"), "--out", str(tmp_path / "x.bin")],
        [str(tmp_path / "short.bin")],
        [str(tmp_path / "missing.xml")],
        [str(tmp_path)],
        [str(esi)],
        [str(esi), "--device", "A-1@1", "--out", str(tmp_path / "notsii.txt")],
        [str(esi), "--device", "A-1@1", "--out", str(link)],
        [str(esi), "--device", "A-1@1", "--out", str(tmp_path / "no" / "x.bin")],
        [str(tmp_path / "short.bin"), "--out", str(tmp_path / "x.bin")],
        [""],
    ):
        code, _, err = _run(capsys, "sii", *argv)
        assert code == 2, argv
        assert err.startswith("skinframes: error:") and err.count("\n") == 1, (argv, err)
    assert (tmp_path / "notsii.txt").read_text() == "hello\n" and not os.path.lexists(
        tmp_path / "target.bin"
    )
    args = [str(esi), "--device", "A-1@1", "--out", str(tmp_path / "notsii.txt"), "--force"]
    assert _run(capsys, "sii", *args)[0] == 0


def test_a_bad_checksum_is_reported_not_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from emulator.slave.sii import SlaveInfo, build_sii

    raw = bytearray(build_sii(SlaveInfo.skin_patch(16)))
    raw[14] ^= 0xFF
    path = tmp_path / "bad.bin"
    path.write_bytes(bytes(raw))
    code, text, _ = _run(capsys, "sii", str(path), "--json")
    assert code == 0 and [f["code"] for f in json.loads(text)["findings"]] == ["sii.checksum"]


def test_a_cut_image_is_reported_short(
    shared_esi: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "s250.bin"  # the user's report: 250 of the image's 256 bytes
    path.write_bytes((shared_esi / "soes_linux_lan9252demo.bin").read_bytes()[:250])
    code, text, _ = _run(capsys, "sii", str(path), "--json")
    assert code == 0 and json.loads(text)["findings"] == [
        {
            "severity": "warning",
            "code": "sii.short",
            "message": "SII: 250 bytes, the size word says 256",
        }
    ]


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        # the user's report (before: "SII: ..." without element or line, or struct's messages);
        # lines 25 (Type), 31 (the first Sm) and 58 (ByteSize) of BogusIO.xml
        ("<ByteSize>2048", "<ByteSize>100", "line 58: <ByteSize>: 100 is not a multiple of 128"),
        (
            "<ByteSize>2048",
            "<ByteSize>2000000000",
            "line 58: <ByteSize>: 2000000000 is outside 128..8388608",
        ),
        (
            'ProductCode="#xB0901030"',
            'ProductCode="#x1B0901030"',
            "line 25: <Type>: ProductCode=#x1B0901030 is outside 0..4294967295",
        ),
        (
            'RevisionNo="42"',
            'RevisionNo="-1"',
            "line 25: <Type>: RevisionNo=-1 is outside 0..4294967295",
        ),
        (
            'StartAddress="#x1800"',
            'StartAddress="#x11800"',
            "line 31: <Sm>: StartAddress=#x11800 is outside 0..65535",
        ),
        (
            'ControlByte="#x64"',
            'ControlByte="#x164"',
            "line 31: <Sm>: ControlByte=#x164 is outside 0..255",
        ),
    ],
)
def test_a_value_outside_its_sii_field_names_the_element_and_line(
    shared_esi: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    old: str,
    new: str,
    message: str,
) -> None:
    text = (shared_esi / "hw_device_mgr_BogusIO.xml").read_text(encoding="utf-8")
    assert text.count(old) == 1
    path = tmp_path / "m.xml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    code, _, err = _run(capsys, "sii", str(path), "--json")
    assert (code, err) == (2, f"skinframes: error: {path}: {message}\n")
