"""``skinframes sii ESI.xml --device SEL --json`` shows what the XML says, device by device.

For every device of every ESI file in ../shared/esi (and, for a local check, of every ``*.xml``
in the folder ``$SKINFRAMES_MORE_ESI`` names: vendor files that may not be committed here), the
JSON document of the image the command builds is compared with the XML read here with
ElementTree and XPath of its own (not with skinframes.esi): identity, ConfigData, EEPROM size,
mailbox protocols, standard and bootstrap mailboxes, SyncManagers, FMMUs, PDOs with their
entries (unless the command says it left the PDO categories out to fit ByteSize) and the number
of dictionary objects. Each device is picked as ``PRODUCTCODE@REVISION``, which names one device
even in files that describe several revisions of a type.
"""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
from conftest import SHARED_ESI

from skinframes_cli import main

MORE = os.environ.get("SKINFRAMES_MORE_ESI", "")
# ETG.2000 names -> the names sii --json gives (docs/interface.md, skinframes sii)
SM_TYPES = {
    "MBoxOut": "mailbox_out",
    "MBoxIn": "mailbox_in",
    "Outputs": "outputs",
    "Inputs": "inputs",
}
FMMU_USES = {"Outputs": "outputs", "Inputs": "inputs", "MBoxState": "syncm_status"}
PROTOCOLS = ("AoE", "EoE", "CoE", "FoE", "SoE", "VoE")
CONFIG_AREA = 14  # words 0-6


def esi_files() -> list[Path]:
    folders = [SHARED_ESI] + ([Path(MORE)] if MORE else [])
    return sorted(p for f in folders if f.is_dir() for p in f.glob("*.xml"))


def number(text: str | None) -> int:
    s = (text or "").strip()
    return int(s[2:], 16) if s[:2] in ("#x", "0x") else int(s)


def devices() -> list[Any]:
    """(file, position of the Device, selector) for every device of every file."""
    out = []
    for path in esi_files():
        root = ET.parse(path).getroot()
        for k, d in enumerate(root.iterfind("Descriptions/Devices/Device")):
            t = d.find("Type")
            assert t is not None
            selector = (
                f"{number(t.get('ProductCode', '0')):#x}@{number(t.get('RevisionNo', '0')):#x}"
            )
            out.append(pytest.param(path, k, selector, id=f"{path.stem}[{k}]"))
    return out


def pdos(device: ET.Element, tag: str) -> list[tuple[int, int | None, list[tuple[int, int, int]]]]:
    return [
        (
            number(p.findtext("Index")),
            None if p.get("Sm") is None else number(p.get("Sm")),
            [
                (
                    number(e.findtext("Index")),
                    number(e.findtext("SubIndex") or "0"),
                    number(e.findtext("BitLen")),
                )
                for e in p.iterfind("Entry")
            ],
        )
        for p in device.iterfind(tag)
    ]


def shown_pdos(doc_pdos: list[dict[str, Any]]) -> list[tuple[int, int, list[tuple[int, int, int]]]]:
    return [
        (p["index"], p["sm"], [(e["index"], e["subindex"], e["bits"]) for e in p["entries"]])
        for p in doc_pdos
    ]


@pytest.mark.parametrize(("path", "position", "selector"), devices())
def test_sii_json_shows_what_the_xml_says(
    path: Path, position: int, selector: str, capsys: pytest.CaptureFixture[str]
) -> None:
    root = ET.parse(path).getroot()
    device = root.findall("Descriptions/Devices/Device")[position]
    if device.find("Eeprom/ByteSize") is None:  # no SII to build: one error line
        assert main(["sii", str(path), "--device", selector, "--json"]) == 2
        assert capsys.readouterr().err.count("\n") == 1
        return
    assert main(["sii", str(path), "--device", selector, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    type_el = device.find("Type")
    assert type_el is not None
    assert (doc["vendor_id"], doc["product_code"], doc["revision"]) == (
        number(root.findtext("Vendor/Id")),
        number(type_el.get("ProductCode")),
        number(type_el.get("RevisionNo")),
    )
    assert doc["esi"]["type"] == (type_el.text or "").strip()
    config = bytes.fromhex("".join((device.findtext("Eeprom/ConfigData") or "").split()))
    assert doc["config_data"] == config[:CONFIG_AREA].ljust(CONFIG_AREA, b"\0").hex()
    assert doc["eeprom_bytes"] == number(device.findtext("Eeprom/ByteSize"))
    assert set(doc["mailbox_protocols"]) == {
        p.lower() for p in PROTOCOLS if device.find(f"Mailbox/{p}") is not None
    }
    sms = device.findall("Sm")
    mailbox = {(s.text or "").strip(): s for s in sms}
    assert doc["standard_mailboxes"] == [
        [number(m.get("StartAddress")), number(m.get("DefaultSize"))] if m is not None else [0, 0]
        for m in (mailbox.get("MBoxOut"), mailbox.get("MBoxIn"))
    ]
    bootstrap = device.findtext("Eeprom/BootStrap")
    if bootstrap is not None:
        raw = bytes.fromhex("".join(bootstrap.split()))
        words = [int.from_bytes(raw[i : i + 2], "little") for i in range(0, 8, 2)]
        assert doc["bootstrap_mailboxes"] == [words[:2], words[2:]]
    assert [
        (s["start"], s["length"], s["control"], s["enable"], s["type"]) for s in doc["syncmanagers"]
    ] == [
        (
            number(s.get("StartAddress")),
            number(s.get("DefaultSize", "0")),
            number(s.get("ControlByte")),
            number(s.get("Enable", "0")),
            SM_TYPES[(s.text or "").strip()],
        )
        for s in sms
    ]
    assert doc["fmmus"] == [FMMU_USES[(f.text or "").strip()] for f in device.iterfind("Fmmu")]
    if any("PDO categories" in w for w in doc["esi"]["left_out"]):
        assert device.find("Mailbox/CoE") is not None  # only a CoE device loses them
        assert (doc["txpdos"], doc["rxpdos"]) == ([], [])
    else:
        for tag, key in (("TxPdo", "txpdos"), ("RxPdo", "rxpdos")):
            expected = pdos(device, tag)
            shown = shown_pdos(doc[key])
            assert [(i, e) for i, _, e in shown] == [(i, e) for i, _, e in expected]
            # the SyncManager of each PDO the ESI assigns (an unassigned one: see the SII's code)
            assert [
                s for (_, s, _), (_, x, _) in zip(shown, expected, strict=True) if x is not None
            ] == [x for _, x, _ in expected if x is not None]
    dictionary = device.find("Profile/Dictionary")
    assert doc["esi"]["objects"] == (
        None if dictionary is None else len(dictionary.findall("Objects/Object"))
    )
    print(
        f"\n{path.name} {selector} {doc['esi']['type']}: {doc['esi']['objects']} objects, "
        f"{len(doc['txpdos'])}+{len(doc['rxpdos'])} PDOs, left out {doc['esi']['left_out']}"
    )
