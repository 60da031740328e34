"""``skinframes sii ESI.xml --device SEL --json`` shows what the XML says, device by device.

For every device of every ESI file in ../shared/esi and tests/data/esi (ours: a modular coupler,
a CoE device without 0x1C00) and, for a local check, of every ``*.xml`` in the folder
``$SKINFRAMES_MORE_ESI`` names (vendor files that may not be committed here), the
JSON document of the image the command builds is compared with the XML read here with
ElementTree and XPath of its own (not with skinframes.esi): identity, ConfigData, EEPROM size,
mailbox protocols, standard and bootstrap mailboxes, SyncManagers, FMMUs, PDOs with their
entries (unless the command says it left the PDO categories out to fit ByteSize), the number
of dictionary objects and, for a modular device (ETG.2000 ``Slots``), its slots and the modules
of the file they may hold, with the modules' PDOs. Each device is picked as ``PRODUCTCODE@REVISION``, which names one device
even in files that describe several revisions of a type.
"""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
from conftest import ROOT, SHARED_ESI

from skinframes_cli import main

MORE = os.environ.get("SKINFRAMES_MORE_ESI", "")
OURS = ROOT / "tests" / "data" / "esi"
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
    folders = [SHARED_ESI, OURS] + ([Path(MORE)] if MORE else [])
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


def flag(el: ET.Element, name: str) -> bool:
    return (el.get(name) or "0").strip().lower() in ("1", "true")


def optional(el: ET.Element, name: str) -> int | None:
    text = el.get(name)
    return None if text is None else number(text)


def english(el: ET.Element) -> str:
    """The text of the first ``Name`` in English (LcId 1033) or without LcId, else ""."""
    for n in el.iterfind("Name"):
        if n.get("LcId") in (None, "1033"):
            return (n.text or "").strip()
    return ""


def lacking_sm_objects(device: ET.Element) -> list[int]:
    """0x1C00, 0x1C10 + n (n: an Outputs/Inputs Sm) and the Index of each RxPdo/TxPdo, those a
    CoE device's Dictionary lacks (docs/interface.md, skinframes sii)."""
    sms = [(s.text or "").strip() for s in device.iterfind("Sm")]
    if device.find("Mailbox/CoE") is None or not sms:
        return []
    objects = device.iterfind("Profile/Dictionary/Objects/Object")
    have = {number(o.findtext("Index")) for o in objects}
    wanted = [0x1C00] + [0x1C10 + k for k, kind in enumerate(sms) if kind in ("Outputs", "Inputs")]
    wanted += [
        number(p.findtext("Index")) for tag in ("RxPdo", "TxPdo") for p in device.iterfind(tag)
    ]
    return list(dict.fromkeys(i for i in wanted if i not in have))


def xml_slots(device: ET.Element) -> dict[str, Any] | None:
    """``Slots`` as ETG.2000 writes them (EtherCATInfo.xsd SlotType)."""
    s = device.find("Slots")
    if s is None:
        return None
    slots = []
    for slot in s.iterfind("Slot"):
        idents = slot.findall("ModuleIdent")
        defaults = [number(i.text) for i in idents if number(i.get("Default", "0"))]
        slots.append(
            {
                "name": english(slot),
                "min_instances": number(slot.get("MinInstances")),
                "max_instances": number(slot.get("MaxInstances")),
                "module_idents": [number(i.text) for i in idents],
                "default_module_ident": defaults[0] if defaults else None,
                "module_classes": [
                    (c.findtext("Class") or "").strip() for c in slot.iterfind("ModuleClass")
                ],
                "slot_index_increment": optional(slot, "SlotIndexIncrement"),
                "slot_pdo_increment": optional(slot, "SlotPdoIncrement"),
            }
        )
    return {
        "slot_index_increment": number(s.get("SlotIndexIncrement", "0")),
        "slot_pdo_increment": number(s.get("SlotPdoIncrement", "0")),
        "max_slot_count": optional(s, "MaxSlotCount"),
        "download_module_ident_list": flag(s, "DownloadModuleIdentList"),
        "slots": slots,
    }


def xml_modules(root: ET.Element, slots: dict[str, Any] | None) -> list[dict[str, Any]]:
    """The file's modules a slot may hold: by ModuleIdent or by ModuleClass, in file order."""
    if slots is None:
        return []
    idents = {i for s in slots["slots"] for i in s["module_idents"]}
    classes = {c for s in slots["slots"] for c in s["module_classes"]}
    out = []
    for m in root.iterfind("Descriptions/Modules/Module"):
        t = m.find("Type")
        assert t is not None
        if number(t.get("ModuleIdent")) not in idents and t.get("ModuleClass") not in classes:
            continue
        out.append(
            {
                "module_ident": number(t.get("ModuleIdent")),
                "type": (t.text or "").strip(),
                "module_class": t.get("ModuleClass"),
                "module_pdo_group": optional(t, "ModulePdoGroup"),
                "txpdos": module_pdos(m, "TxPdo"),
                "rxpdos": module_pdos(m, "RxPdo"),
                "objects": None
                if m.find("Profile/Dictionary") is None
                else len(m.findall("Profile/Dictionary/Objects/Object")),
            }
        )
    return out


def module_pdos(module: ET.Element, tag: str) -> list[Any]:
    """(index, Sm, DependOnSlot, [(index, subindex, bits, DependOnSlot)]) of each PDO."""
    out = []
    for p in module.iterfind(tag):
        index = p.find("Index")
        assert index is not None
        entries = []
        for e in p.iterfind("Entry"):
            e_index = e.find("Index")
            assert e_index is not None
            entries.append(
                (
                    number(e_index.text),
                    number(e.findtext("SubIndex") or "0"),
                    number(e.findtext("BitLen")),
                    flag(e_index, "DependOnSlot"),
                )
            )
        out.append((number(index.text), optional(p, "Sm"), flag(index, "DependOnSlot"), entries))
    return out


def shown_modules(modules: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The keys :func:`xml_modules` gives, from the command's ``esi.modules``."""
    out = []
    for m in modules:
        shown = {k: m[k] for k in ("module_ident", "type", "module_class", "module_pdo_group")}
        for key in ("txpdos", "rxpdos"):
            shown[key] = [
                (
                    p["index"],
                    p["sm"],
                    p["depend_on_slot"],
                    [
                        (e["index"], e["subindex"], e["bits"], e["depend_on_slot"])
                        for e in p["entries"]
                    ],
                )
                for p in m[key]
            ]
        shown["objects"] = m["objects"]
        out.append(shown)
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
    assert doc["esi"]["added_objects"] == lacking_sm_objects(device)
    slots = xml_slots(device)
    assert doc["esi"]["slots"] == slots
    assert shown_modules(doc["esi"]["modules"]) == xml_modules(root, slots)
    print(
        f"\n{path.name} {selector} {doc['esi']['type']}: {doc['esi']['objects']} objects, "
        f"{len(doc['txpdos'])}+{len(doc['rxpdos'])} PDOs, left out {doc['esi']['left_out']}, "
        f"{len(doc['esi']['modules'])} modules"
    )


def test_a_modular_device_s_image_holds_its_own_pdos_and_the_json_its_modules(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """tests/data/esi/modular_coupler.xml, read by eye: the SII has the coupler's one fixed
    TxPDO 0x1AFF (module PDOs are the slot configuration's, ETG.5001), and the modules its
    slots may hold are HEAD-A and HEAD-B (by ident; the third ident, 0x19999, has no Module)
    and DI-8 and DO-4 (by class); AI-2 is in no slot."""
    assert main(["sii", str(OURS / "modular_coupler.xml"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [(p["index"], p["sm"]) for p in doc["txpdos"]] == [(0x1AFF, 3)]
    assert doc["rxpdos"] == []
    assert [m["type"] for m in doc["esi"]["modules"]] == ["HEAD-A", "HEAD-B", "DI-8", "DO-4"]
    assert [m["name"] for m in doc["esi"]["modules"]][2] == "DI-8 inputs"  # LcId 1033
    head, io = doc["esi"]["slots"]["slots"]
    assert (head["module_idents"], head["default_module_ident"]) == (
        [0x10002, 0x10001, 0x19999],
        0x10001,
    )
    assert (io["module_classes"], io["slot_index_increment"], io["slot_pdo_increment"]) == (
        ["DI", "DO"],
        0x20,
        2,
    )
