"""Live: pysoem drives ``serve ecat --esi`` (slaves described by third-party ESI files) over veth.

Expected values come from the ESI XML (read here with ElementTree, not with skinframes.esi)
and from the SII images their makers shipped beside them (../shared/esi, SOURCES.md):

* ``serve ecat --nodes 0 --esi lan9252 --esi dynpdo``: ``config_init`` finds both with the
  ESI's vendor, product code and revision; SOEM's EEPROM reads return the image ``skinframes
  sii`` writes, which equals the shipped one on the words SOURCES.md lists; ``slave.od`` lists
  exactly the ESI's objects; ``sdo_read(0x1018, 1)`` is the vendor id; ``config_map`` gives each
  the bytes of its default PDO assignment (the PDOs with an ``Sm``); both reach OP and their
  inputs count up;
* 20 skin patches and one ESI slave in one line: SOEM reaches OP, every cycle's working
  counter is the expected one;
* ``--esi-inputs``: the input entry plays the rows of a file written here, in turn;
* an ESI whose dictionary lacks 0x1C00, 0x1C12 and 0x1C13 (tests/data/esi/coe_without_1c00.xml,
  ours): SOEM reads them in PRE-OP as every CoE slave with SyncManagers serves them, and
  ``config_map`` (which raised ConfigMapError on the SDO aborts) maps the default assignment.

Root (or CAP_NET_RAW, CAP_NET_ADMIN, CAP_SYS_ADMIN), iproute2 and pysoem are needed: without
them the tests skip with the reason, under CI=true they fail.
"""

from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from live_util import (
    ENV,
    ROOT,
    TESTS,
    counts_up,
    from_xml,
    in_netns,
    live_net,
    serving,
    xml_number,
)

from emulator.live import VethPair

LAN9252, DYNPDO = "soes_linux_lan9252demo", "soes_rtl_xmc4_dynpdo"
NO_1C00 = ROOT / "tests" / "data" / "esi" / "coe_without_1c00.xml"
SM_TYPES = {"MBoxOut": 1, "MBoxIn": 2, "Outputs": 3, "Inputs": 4}  # ETG.1000.6 0x1C00 values
PATCHES, PATCH_BYTES = 20, 192


@pytest.fixture(scope="module")
def net() -> Iterator[VethPair]:
    yield from live_net("esi")


def run_master(net: VethPair, *args: str) -> dict[str, Any]:
    done = in_netns(net, sys.executable, str(TESTS / "soem_esi_master.py"), net.master, *args)
    assert done.returncode == 0, done.stderr[-3000:]
    doc: dict[str, Any] = json.loads(done.stdout.splitlines()[-1])
    return doc


def sii_image(shared_esi: Path, name: str, tmp_path: Path) -> bytes:
    """The image ``skinframes sii`` writes for the ESI (the command as users run it)."""
    out = tmp_path / f"{name}.bin"
    subprocess.run(
        [sys.executable, "-m", "skinframes", "sii", str(shared_esi / f"{name}.xml"), "--out", out],
        cwd=ROOT,
        env=ENV,
        check=True,
        capture_output=True,
    )
    return out.read_bytes()


# the words SOURCES.md lists as agreeing between each shipped image and its ESI: words 0-7
# (ConfigData, checksum), vendor/product/revision (8-13), bootstrap and standard mailboxes and
# the protocols (0x14-0x1C), size and version (0x3E-0x3F); the serial (14-15) is the maker's
AGREED_BYTE_RANGES = ((0, 16), (16, 28), (0x28, 0x3A), (0x7C, 0x80))


def test_pysoem_brings_two_esi_slaves_to_op(
    net: VethPair, shared_esi: Path, tmp_path: Path
) -> None:
    names = (LAN9252, DYNPDO)
    xml = [from_xml(shared_esi / f"{n}.xml") for n in names]
    images = [sii_image(shared_esi, n, tmp_path) for n in names]
    for image, n in zip(images, names, strict=True):
        shipped = (shared_esi / f"{n}.bin").read_bytes()
        for lo, hi in AGREED_BYTE_RANGES:
            assert image[lo:hi] == shipped[lo:hi], (n, lo, hi)
    specs = [a for n in names for a in ("--esi", str(shared_esi / f"{n}.xml"))]
    with serving(net, "--nodes", "0", *specs) as server:
        doc = run_master(net, "--image-bytes", *(str(len(i)) for i in images))
    assert server["rc"] == 0, server["stderr"]
    assert doc["config_init"] == 2
    for found, x in zip(doc["slaves"], xml, strict=True):
        assert (found["man"], found["id"], found["rev"]) == (
            x["vendor_id"],
            x["product_code"],
            x["revision"],
        )
        # SOEM names a slave by SII string 1, which holds the Type text in our images and in
        # both shipped ones (theirs: 'evb9252_dig', 'xmc48relax')
        assert found["name"] == x["type"]
    assert [bytes.fromhex(i) for i in doc["images"]] == images  # SOEM's EEPROM reads
    for coe, x in zip(doc["coe"], xml, strict=True):
        assert coe["vendor_id"] == x["vendor_id"]  # sdo_read(0x1018, 1)
        assert {o[0] for o in coe["od"]} == x["objects"]  # slave.od: the ESI's objects
    assert doc["io_bytes"] == [[x["output_bytes"], x["input_bytes"]] for x in xml]
    assert doc["iomap_bytes"] == sum(x["output_bytes"] + x["input_bytes"] for x in xml)
    # one LRW: outputs count 2 at each slave with outputs, inputs 1 (ETG.1000.4 Table 14)
    expected_wkc = sum(2 * bool(x["output_bytes"]) + bool(x["input_bytes"]) for x in xml)
    assert doc["expected_wkc"] == expected_wkc
    assert (doc["safeop"], doc["op"], doc["states"]) == (4, 8, [8, 8])
    assert doc["al_status_codes"] == [0, 0]
    assert doc["wkc"] == [expected_wkc] * len(doc["wkc"])
    for k in range(2):  # one input byte each: the publication counter, cut to 8 bits
        assert counts_up([int(row[k], 16) for row in doc["inputs"]], 256)
    assert doc["init"] == 1
    summary = server["summary"]
    assert [(e["vendor_id"], e["product_code"]) for e in summary["esi"]] == [
        (x["vendor_id"], x["product_code"]) for x in xml
    ]
    assert (summary["nodes"], summary["dropped"], summary["errors"]) == (0, 0, 0)
    print(
        f"\n{names}: {[s['name'] for s in doc['slaves']]}, io {doc['io_bytes']}, wkc "
        f"{expected_wkc}, objects {[len(c['od']) for c in doc['coe']]}, inputs "
        f"{doc['inputs'][0]}..{doc['inputs'][-1]}, {summary['frames_in']} frames"
    )


def test_pysoem_brings_patches_and_an_esi_slave_to_op(net: VethPair, shared_esi: Path) -> None:
    x = from_xml(shared_esi / f"{LAN9252}.xml")
    with serving(
        net,
        *("--nodes", str(PATCHES), "--bytes", str(PATCH_BYTES)),
        *("--esi", str(shared_esi / f"{LAN9252}.xml")),
    ) as server:
        doc = run_master(net, "--image-bytes", str(x["byte_size"]))
    assert server["rc"] == 0, server["stderr"]
    assert doc["config_init"] == PATCHES + 1
    last = doc["slaves"][-1]
    assert (last["man"], last["id"], last["rev"]) == (
        x["vendor_id"],
        x["product_code"],
        x["revision"],
    )
    assert doc["iomap_bytes"] == PATCHES * PATCH_BYTES + x["output_bytes"] + x["input_bytes"]
    expected_wkc = PATCHES + 2 * bool(x["output_bytes"]) + bool(x["input_bytes"])
    assert doc["expected_wkc"] == expected_wkc
    assert (doc["safeop"], doc["op"]) == (4, 8)
    assert doc["states"] == [8] * (PATCHES + 1)
    assert doc["wkc"] == [expected_wkc] * len(doc["wkc"])
    assert counts_up([int(row[0], 16) for row in doc["inputs"]], 256)
    assert server["summary"]["errors"] == 0
    print(
        f"\n{PATCHES} x {PATCH_BYTES} B + {last['name']}: iomap {doc['iomap_bytes']} B, wkc "
        f"{expected_wkc}, states {sorted(set(doc['states']))}, "
        f"{server['summary']['frames_in']} frames"
    )


def test_pysoem_reads_inputs_from_a_file(net: VethPair, shared_esi: Path, tmp_path: Path) -> None:
    """``--esi-inputs``: the slave's one input entry (0x6000:1, 8 bits, the XML's TxPdo) plays
    the file's rows in turn, a row per publication, and pysoem reads nothing else."""
    x = from_xml(shared_esi / f"{LAN9252}.xml")
    rows = [(37 * k + 5) % 256 for k in range(16)]  # distinct, in an order a counter lacks
    inputs = tmp_path / "inputs.csv"
    inputs.write_text("# Button1\n0x6000:1\n" + "".join(f"{v}\n" for v in rows), encoding="utf-8")
    with serving(
        net,
        "--nodes",
        "0",
        "--esi",
        str(shared_esi / f"{LAN9252}.xml"),
        "--esi-inputs",
        str(inputs),
    ) as server:
        doc = run_master(net, "--image-bytes", str(x["byte_size"]))
    assert server["rc"] == 0, server["stderr"]
    assert (doc["op"], doc["states"]) == (8, [8])
    seen = [int(row[0], 16) for row in doc["inputs"]]
    assert set(seen) <= set(rows), sorted(set(seen) - set(rows))
    assert counts_up([rows.index(v) for v in seen], len(rows))  # row after row, repeated
    assert server["summary"]["esi"][0]["inputs"] == str(inputs)
    print(f"\n--esi-inputs: {len(set(seen))} of {len(rows)} rows seen in {len(seen)} cycles")


def test_pysoem_maps_an_esi_slave_whose_dictionary_lacks_0x1c00(net: VethPair) -> None:
    """SOEM's PDO-map reader (ec_coe.c, ecx_readPDOmap) reads 0x1C00:0 (how many
    SyncManagers), each SyncManager's type 0x1C00:n, then 0x1C1n of each process-data one; an
    SDO abort there left an error pysoem's ``config_map`` raised as ConfigMapError. A real
    CoE slave serves them (ETG.1000.6 5.6.7.4; SOES always does): the emulated one makes them
    from the ESI's Sm elements and default assignment (the PDOs with an Sm)."""
    x = from_xml(NO_1C00)
    device = ET.parse(NO_1C00).getroot().find("Descriptions/Devices/Device")
    assert device is not None
    types = [SM_TYPES[(s.text or "").strip()] for s in device.iterfind("Sm")]
    assigned = {
        n: [xml_number(p.findtext("Index")) for p in device.iterfind(tag) if p.get("Sm") == str(n)]
        for n, tag in ((2, "RxPdo"), (3, "TxPdo"))
    }
    assert not {0x1C00, 0x1C12, 0x1C13} & x["objects"]  # what the ESI lacks
    reads = ["0x1C00:0", *(f"0x1C00:{k}" for k in range(1, len(types) + 1))]
    reads += ["0x1C12:0", "0x1C12:1", "0x1C13:0", "0x1C13:1"]
    with serving(net, "--nodes", "0", "--esi", str(NO_1C00)) as server:
        doc = run_master(
            net, "--image-bytes", str(x["byte_size"]), *(a for r in reads for a in ("--sdo", r))
        )
    assert server["rc"] == 0, server["stderr"]
    sdo = {k: bytes.fromhex(v) for k, v in doc["coe"][0]["sdo"].items()}
    assert sdo["0x1C00:0"] == bytes([len(types)])
    assert [sdo[f"0x1C00:{k}"][0] for k in range(1, len(types) + 1)] == types == [1, 2, 3, 4]
    for n in (2, 3):
        assert sdo[f"0x1C1{n}:0"] == bytes([len(assigned[n])])
        assert int.from_bytes(sdo[f"0x1C1{n}:1"], "little") == assigned[n][0]
    assert {o[0] for o in doc["coe"][0]["od"]} == x["objects"] | {0x1C00, 0x1C12, 0x1C13}
    assert doc["io_bytes"] == [[x["output_bytes"], x["input_bytes"]]] == [[3, 3]]
    assert (doc["safeop"], doc["op"], doc["states"], doc["al_status_codes"]) == (4, 8, [8], [0])
    assert doc["wkc"] == [3] * len(doc["wkc"])  # outputs 2 + inputs 1 (ETG.1000.4 Table 14)
    counters = [int.from_bytes(bytes.fromhex(row[0])[:2], "little") for row in doc["inputs"]]
    assert counts_up(counters, 1 << 16)  # 0x6000:1, the first 16 bits (UINT, little-endian)
    print(f"\n{x['type']}: 0x1C00 {types}, assigned {assigned}, io {doc['io_bytes']}")


def test_pysoem_maps_a_modular_device_with_modules_in_its_slots(net: VethPair) -> None:
    """``--esi-modules HEAD-A,DI-8,DO-4`` on tests/data/esi/modular_coupler.xml (ours), by hand
    from the XML: HEAD-A is slot 0 of the Head slot, DI-8 slot 1 and DO-4 slot 2 of the IO slot
    (SlotPdoIncrement 2, SlotIndexIncrement 0x20). SOEM reads 0x1C12 = [0x1601 + 2 * 2] and
    0x1C13 = [0x1AFF (the coupler's), 0x1A00 (HEAD-A), 0x1A01 + 1 * 2 (DI-8)] and their
    mappings: outputs 4 + 4 bits = 1 byte, inputs 16 + 8 + (1 + 1 + 6) bits = 4 bytes. 0xF030
    holds the three idents (ETG.5001); the SII has the coupler's 0x1AFF alone."""
    path = ROOT / "tests" / "data" / "esi" / "modular_coupler.xml"
    x = from_xml(path)
    reads = ["0x1C12:1", "0x1C13:0", "0x1C13:1", "0x1C13:2", "0x1C13:3", "0xF030:0"]
    reads += ["0xF030:1", "0xF030:2", "0xF030:3", "0x1A03:1", "0x1605:1"]
    with serving(
        net, "--nodes", "0", "--esi", str(path), "--esi-modules", "HEAD-A,DI-8,DO-4"
    ) as server:
        doc = run_master(
            net, "--image-bytes", str(x["byte_size"]), *(a for r in reads for a in ("--sdo", r))
        )
    assert server["rc"] == 0, server["stderr"]
    sdo = {k: int.from_bytes(bytes.fromhex(v), "little") for k, v in doc["coe"][0]["sdo"].items()}
    assert sdo["0x1C12:1"] == 0x1605
    assert [sdo[f"0x1C13:{k}"] for k in range(4)] == [3, 0x1AFF, 0x1A00, 0x1A03]
    assert [sdo[f"0xF030:{k}"] for k in range(4)] == [3, 0x00010001, 0x00020001, 0x00020002]
    assert sdo["0x1A03:1"] == 0x6030_01_01  # DI-8's 0x6010:1, moved by 0x20
    assert sdo["0x1605:1"] == 0x7050_01_04  # DO-4's 0x7010:1, moved by 2 * 0x20
    assert doc["io_bytes"] == [[1, 4]]
    assert (doc["safeop"], doc["op"], doc["states"], doc["al_status_codes"]) == (4, 8, [8], [0])
    assert doc["wkc"] == [3] * len(doc["wkc"])
    print(f"\n{x['type']} with HEAD-A, DI-8, DO-4: io {doc['io_bytes']}, 0x1C13 {sdo['0x1C13:0']}")
