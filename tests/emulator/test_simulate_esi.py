"""``simulate ecat --esi``: ESI slaves after the patches, their inputs in the emulated frames.

Expected values from the ESI files (../shared/esi) and by hand: soes_linux_lan9252demo.xml maps one TxPDO 0x1A00 with one 8-bit entry 0x6000:01 on Sm 3
(1 input byte, 2 output bytes); soes_tiesc_k2gice.xml one 32-bit UDINT 0x6000:00 on Sm 3
(4 input bytes). Behind two patches of 192 bytes the master reads them at logical 384 and 385,
each with its own LRD (index = position), and in cycle c each holds c + 1, cut to its bits.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import tshark_util

from emulator.model.params import PAPER
from emulator.net.api import simulate_ecat
from emulator.net.run import MemorySink
from emulator.slave.esi_slave import counter_images
from skinframes.dispatch import decode_frame
from skinframes.ethercat import Command, EcatFrame
from skinframes_cli import main

DEMO = "soes_linux_lan9252demo.xml"
K2G = "soes_tiesc_k2gice.xml"


def test_counter_images_packs_entries_bit_by_bit() -> None:
    """ETG.1000.6 5.6.7 by hand: a 1-bit entry at bit 0, a 3-bit gap, a 4-bit entry at bits 4-7,
    a 16-bit entry in the next two bytes; counter 5 -> 0x51 0x05 0x00; 0x10003 -> 0x31 0x03 0x00
    (each entry the counter cut to its bits)."""
    layout = [(0x6000, 1, 1), (0, 0, 3), (0x6000, 2, 4), (0x6001, 0, 16)]
    rows = counter_images(layout, np.array([5, 0x10003], dtype=np.int64))
    assert [bytes(r).hex() for r in rows] == ["510500", "310300"]


def _returned_lrds(sink: MemorySink) -> list[dict[int, tuple[int, int, bytes]]]:
    """Per returned frame: LRD index -> (logical address, WKC, data)."""
    out = []
    for _, _, outbound, frame, _ in sink.records:
        if outbound:
            continue
        ecat = decode_frame(frame).payload
        assert isinstance(ecat, EcatFrame)
        out.append(
            {
                d.idx: (d.adp | d.ado << 16, d.wkc, d.data)
                for d in ecat.datagrams
                if d.cmd == Command.LRD
            }
        )
    return out


@pytest.mark.parametrize("fast", [True, False])
def test_esi_inputs_count_the_cycles(shared_esi: Path, fast: bool) -> None:
    sink = MemorySink()
    cycles = 300  # past 256: the 8-bit entry wraps, the 32-bit one does not
    esi = (str(shared_esi / DEMO), str(shared_esi / K2G))
    result = simulate_ecat(2, 192, PAPER, cycles=cycles, sink=sink, esi=esi, fast=fast)
    frames = _returned_lrds(sink)
    assert len(frames) == cycles  # 2 x 204 + 13 + 16 bytes of datagrams: one frame a cycle
    for c, lrds in enumerate(frames):
        assert lrds[2] == (384, 1, bytes([(c + 1) % 256]))
        assert lrds[3] == (385, 1, (c + 1).to_bytes(4, "little"))
        assert [lrds[i][:2] for i in (0, 1)] == [(0, 1), (192, 1)]
    assert result.nodes == 2
    assert {(d.wkc, d.expected_wkc) for d in result.details} == {(4, 4)}


def test_fast_path_writes_the_walked_bytes(shared_esi: Path) -> None:
    sinks = [MemorySink(), MemorySink()]
    esi = (str(shared_esi / K2G), str(shared_esi / DEMO))
    for sink, fast in zip(sinks, (True, False), strict=True):
        simulate_ecat(1, 16, PAPER, cycles=40, sink=sink, esi=esi, fast=fast)
    assert sinks[0].records == sinks[1].records


@pytest.mark.tshark
@pytest.mark.parametrize(
    "extra", [[], ["--layout", "logical"], ["--startup"], ["--closed-ring", "--nodes", "3"]]
)
def test_simulate_esi_pcap_is_clean(
    tshark: str, shared_esi: Path, tmp_path: Path, extra: list[str]
) -> None:
    path = tmp_path / "esi.pcapng"
    argv = ["simulate", "ecat", "--nodes", "2", "--bytes", "192", "--cycles", "3"]
    argv += ["--esi", str(shared_esi / DEMO), "--esi", f"{shared_esi / K2G}#k2gice"]
    argv += ["--pcap", str(path), *extra]
    assert main(argv) == 0
    assert tshark_util.problems(tshark, path) == []
    rows = tshark_util.fields(tshark, path, ["frame.protocols", "ecat.lad", "ecat.cnt"])
    # the mailbox frames of the start-up add ecat_mailbox; every other frame is plain EtherCAT
    assert {r["frame.protocols"][0] for r in rows} <= {
        "eth:ethertype:ecatf:ecat",
        "eth:ethertype:ecatf:ecat:ecat_mailbox",
    }
    cycles = rows[-6:] if "--closed-ring" not in extra else rows[-12:]
    lads = {int(v, 0) for r in cycles for v in r["ecat.lad"]}
    nodes = 3 if "--closed-ring" in extra else 2
    if "--layout" in extra:
        assert lads == {0}  # one LRD of the whole image
    else:
        assert lads == {192 * p for p in range(nodes)} | {192 * nodes, 192 * nodes + 1}
    if "--closed-ring" not in extra:  # a read counts 1 at every slave it reads
        returned = cycles[1::2]
        expected = nodes + 2 if "--layout" in extra else 1
        assert {int(v, 0) for r in returned for v in r["ecat.cnt"]} == {expected}


def test_nodes_0_with_esi_only(shared_esi: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["simulate", "ecat", "--nodes", "0", "--bytes", "1", "--cycles", "2", "--json"]
    assert main([*argv, "--esi", str(shared_esi / DEMO)]) == 0
    out = capsys.readouterr().out
    assert '"esi": [' in out and '"product_code": ' in out and '"vendor_id": 4919' in out


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["ecat", "--nodes", "0", "--bytes", "1"], "--nodes 0: only with --esi"),
        (["epl", "--nodes", "1", "--bytes", "1", "--esi", "x.xml"], "EtherCAT only"),
        (["ecat", "--nodes", "1", "--bytes", "1", "--esi", "/nonexistent.xml"], "--esi /non"),
        (["ecat", "--nodes", "1", "--bytes", "1", "--esi", "DEMO#nosuchtype"], "#nosuchtype"),
    ],
)
def test_bad_esi_is_one_error_line(
    shared_esi: Path, capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    argv = [a.replace("DEMO", str(shared_esi / DEMO)) for a in argv]
    assert main(["simulate", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("skinframes: error: ") and message in err[0]


def test_one_byte_inputs_carry_their_taxels() -> None:
    """A patch of 1 byte: its SyncManager of length 1 is not activated (datasheet II 0x0802:
    length > 1, else not activated), so the FMMU reads plain memory; the frames still carry the
    taxels given (before, they came back 0)."""
    given = np.arange(3 * 4, dtype=np.uint8).reshape(4, 3, 1) + 0xA0
    sink = MemorySink()
    simulate_ecat(3, 1, PAPER, cycles=4, sink=sink, payloads=given)
    for c, lrds in enumerate(_returned_lrds(sink)):
        assert [lrds[p] for p in range(3)] == [(p, 1, bytes([0xA0 + 3 * c + p])) for p in range(3)]


@pytest.mark.tshark
def test_esi_inputs_from_a_file_in_the_pcap(tshark: str, shared_esi: Path, tmp_path: Path) -> None:
    # the LAN9252 demo's one input entry 0x6000:01 (8 bits) from a file of 3 rows; cycle c is
    # publication c + 1 and takes row (c + 1) % 3: 0x22, 0x33, 0x11, 0x22, ... (worked out by
    # hand); the K2G's 32-bit entry, with no file, still counts: c + 1
    inputs = tmp_path / "button.csv"
    inputs.write_text("0x6000:1\n0x11\n0x22\n0x33\n", encoding="utf-8")
    path = tmp_path / "inputs.pcap"
    argv = ["simulate", "ecat", "--nodes", "0", "--bytes", "1", "--cycles", "5"]
    argv += ["--pcap", str(path)]
    argv += ["--esi", str(shared_esi / DEMO), "--esi-inputs", str(inputs)]
    argv += ["--esi", f"{shared_esi / K2G}#k2gice"]
    assert main(argv) == 0
    rows = tshark_util.fields(tshark, path, ["ecat.lad", "ecat.cnt", "ecat.data"])
    returned = [r for r in rows if any(int(v, 0) for v in r["ecat.cnt"])]
    demo = [bytes.fromhex(r["ecat.data"][0]) for r in returned]
    k2g = [bytes.fromhex(r["ecat.data"][1]) for r in returned]
    assert demo == [bytes([v]) for v in (0x22, 0x33, 0x11, 0x22, 0x33)]
    assert k2g == [(c + 1).to_bytes(4, "little") for c in range(5)]
    bad = ["simulate", "epl", "--nodes", "1", "--bytes", "8", "--esi-inputs", str(inputs)]
    assert main(bad) == 2


MODULAR = Path(__file__).resolve().parent.parent / "data" / "esi" / "modular_coupler.xml"


def test_esi_modules_in_the_json(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["simulate", "ecat", "--nodes", "0", "--bytes", "1", "--cycles", "2", "--json"]
    assert main([*argv, "--esi", str(MODULAR), "--esi-modules", "HEAD-A, 0x20002"]) == 0
    (esi,) = json.loads(capsys.readouterr().out)["esi"]
    assert esi["modules"] == "0x10001,0x20002"  # HEAD-A's and DO-4's ModuleIdent


def test_an_empty_esi_modules_list_suits_a_slave_without_slots(
    capsys: pytest.CaptureFixture[str], shared_esi: Path
) -> None:
    """The docs: ``''`` for a slave without modules, so that the second --esi, a modular one,
    can get its list (the first, the LAN9252 demo, has no Slots)."""
    argv = ["simulate", "ecat", "--nodes", "0", "--bytes", "1", "--cycles", "2", "--json"]
    argv += ["--esi", str(shared_esi / DEMO), "--esi", str(MODULAR)]
    assert main([*argv, "--esi-modules", "", "--esi-modules", "HEAD-A,DO-4"]) == 0
    plain, modular = json.loads(capsys.readouterr().out)["esi"]
    assert "modules" not in plain and modular["modules"] == "0x10001,0x20002"
    # a list that names a module is still refused for it
    assert main([*argv, "--esi-modules", "HEAD-A"]) == 2
    assert "has no <Slots>, so no modules" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--esi-modules", "HEAD-A", "--esi-modules", "HEAD-A"], "2 lists for 1 --esi slaves"),
        (["--esi-modules", "DI-8"], "slot 'Head' (line 87) needs 1 module(s) at least"),
        (["--esi-modules", "HEAD-A,AI-2"], "no module 'AI-2' its slots may hold"),
    ],
)
def test_bad_esi_modules_are_one_error_line(
    capsys: pytest.CaptureFixture[str], extra: list[str], message: str
) -> None:
    argv = ["simulate", "ecat", "--nodes", "0", "--bytes", "1", "--esi", str(MODULAR), *extra]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("skinframes: error: ") and message in err[0]
    assert main(["simulate", "epl", "--nodes", "1", "--bytes", "1", *extra]) == 2
    assert "--esi-modules apply to EtherCAT only" in capsys.readouterr().err


def test_serve_refuses_bad_esi_modules_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    """Checked before any socket is opened: the same loader as simulate's."""
    for argv, message in (
        (["--esi", str(MODULAR), "--esi-modules", "HEAD-A,HEAD-A"], "module 2 (HEAD-A): no slot"),
        (["--esi", str(MODULAR), "--esi-modules", "a", "--esi-modules", "b"], "2 lists for 1"),
    ):
        code = main(["serve", "ecat", "--iface", "lo", "--nodes", "0", *argv])
        err = capsys.readouterr().err
        assert code == 2 and err.startswith("skinframes: error:") and message in err, err
        assert err.count("\n") == 1
    code = main(
        ["serve", "epl", "--iface", "lo", "--nodes", "1", "--bytes", "8", "--esi-modules", ""]
    )
    assert code == 2 and "--esi-modules applies to serve ecat only" in capsys.readouterr().err
