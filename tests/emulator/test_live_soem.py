"""Live: real masters drive ``skinframes serve ecat`` over a veth pair in a private netns.

* pysoem (SOEM 1.4, an unmodified binary wheel) scans, maps, reaches OP and runs 1,000 cycles:
  21 patches x 192 bytes (4,032 bytes: pysoem's 4,096-byte IO map) and 160 x 16 bytes. Every
  cycle must return the expected working counter and the taxel bytes the emulated patches
  published (``skinframes.taxel.sample_payloads`` with the server's seed), whole samples per
  frame, moving forward in time;
* an independent minimal master (tests/mini_master.py: its own frames, its own SII walk);
* ``serve ecat --pcap`` records every frame it receives and sends (a sniffer such as dumpcap
  drops frames when the machine is busy; serve's own record does not), and tshark must find no
  malformed frame in it.

These tests need root (or CAP_NET_RAW, CAP_NET_ADMIN and CAP_SYS_ADMIN), iproute2, tshark and
pysoem. Without them they skip with the reason; under CI=true they fail instead.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import live_util
import numpy as np
import pytest
import tshark_util
from bench_util import load_benchmark
from live_util import (
    ENV,
    IN_CI,
    ROOT,
    TESTS,
    check_taxels,
    missing_requirement,
    read_line,
    sample_of_rows,
    samples_of_rows,
)

from emulator.esc.chain import EcatChain
from emulator.hostile import hostile_frames
from emulator.live import ServeStats, TaxelFeed, VethPair, netns_socket, serve, veth_netns
from emulator.slave.state_machine import AlState
from skinframes import ethercat, taxel
from skinframes.ethercat import Command, Datagram, EcatFrame

SEED, SAMPLES, PERIOD_MS = 20260, 256, 2.0
GROUP_SOURCE_WARNING = "Source MAC must not be a group address"  # SOEM sends from 01:01:...
MAILBOX_STACK = "eth:ethertype:ecatf:ecat:ecat_mailbox"


@pytest.fixture(scope="module")
def live() -> None:
    reason = missing_requirement()
    if reason is not None:
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip(reason)


def netns_names() -> set[str]:
    out = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True, check=True)
    return {line.split()[0] for line in out.stdout.splitlines() if line.strip()}


@pytest.fixture(scope="module")
def net(live: None) -> Iterator[VethPair]:
    with veth_netns() as pair:
        assert pair.netns in netns_names()
        yield pair
    assert pair.netns not in netns_names()


@contextlib.contextmanager
def serving(
    net: VethPair, nodes: int, size: int, pcap: Path | None = None
) -> Iterator[dict[str, Any]]:
    """``skinframes serve ecat`` on the slave end; stopped with SIGINT, its summary kept."""
    with live_util.serving(
        net,
        *("--nodes", str(nodes), "--bytes", str(size)),
        *("--seed", str(SEED), "--samples", str(SAMPLES)),
        *(() if pcap is None else ("--pcap", str(pcap))),
        period_ms=PERIOD_MS,
    ) as result:
        yield result


def run_soem(net: VethPair, inputs: Path, cycles: int = 1000, *options: str) -> dict[str, Any]:
    done = live_util.in_netns(
        net,
        *(sys.executable, str(TESTS / "soem_master.py"), net.master),
        *("--cycles", str(cycles), "--inputs-out", str(inputs), *options),
    )
    assert done.returncode == 0, done.stderr[-3000:]
    doc: dict[str, Any] = json.loads(done.stdout.splitlines()[-1])
    return doc


def check_capture(tshark: str, path: Path) -> int:
    """tshark's verdict on the capture: no malformed frame, no expert item but SOEM's source."""
    malformed = tshark_util.run(
        tshark, path, "-Y", "_ws.malformed", "-T", "fields", "-e", "frame.number"
    )
    assert malformed.strip() == ""
    expert = tshark_util.run(
        tshark,
        path,
        *("-Y", "_ws.malformed || _ws.expert.severity >= warning"),
        *("-T", "fields", "-E", "aggregator=|", "-e", "frame.number", "-e", "_ws.expert.message"),
    )
    for line in expert.splitlines():
        _, _, messages = line.partition("\t")
        assert all(m.startswith(GROUP_SOURCE_WARNING) for m in messages.split("|")), line
    stacks = tshark_util.run(tshark, path, "-T", "fields", "-e", "frame.protocols").split()
    assert stacks and set(stacks) <= {"eth:ethertype:ecatf:ecat", MAILBOX_STACK}
    return len(stacks)


@pytest.mark.tshark
@pytest.mark.parametrize(("nodes", "size"), [(21, 192), (160, 16)])
def test_pysoem_runs_the_emulated_skin(
    net: VethPair, tshark: str, tmp_path: Path, nodes: int, size: int
) -> None:
    inputs = tmp_path / "inputs.bin"
    pcap = tmp_path / "veth.pcapng"
    with serving(net, nodes, size, pcap) as server:
        doc = run_soem(net, inputs, 1000, "--coe")
    assert server["rc"] == 0, server["stderr"]
    assert doc["config_init"] == nodes
    check_coe(doc["coe"], size)
    check_coe_capture(tshark, pcap, doc["coe"])
    for s in doc["slaves"]:  # the identity pysoem read from each SII
        assert (s["man"], s["id"], s["rev"]) == (0x534B494E, 0x00010000 + size, 0x00010000)
        assert s["name"] == f"SkinPatch{size}"
    assert doc["serials"] == list(range(1, nodes + 1))
    assert doc["eeprom_word_0x20"] == "efbe"
    assert doc["iomap_bytes"] == nodes * size
    assert doc["expected_wkc"] == nodes  # one input FMMU per slave
    assert (doc["safeop"], doc["op"], doc["states"]) == (4, 8, [8])
    assert doc["al_status_codes"] == [0]
    assert doc["wkc"] == [nodes] * 1000
    assert doc["init"] == 1
    data = np.fromfile(inputs, dtype=np.uint8)
    assert data.size == 1000 * nodes * size
    distinct = check_taxels(data, nodes, size, seed=SEED, samples=SAMPLES)
    assert distinct > 1  # the patterns changed while the master watched
    frames = check_capture(tshark, pcap)
    summary = server["summary"]
    assert summary["frames_in"] == summary["frames_out"] > 2000
    assert summary["compiled"] or not IN_CI  # make test compiled them: real masters drive that
    assert (summary["dropped"], summary["errors"]) == (0, 0)
    # serve's own record: every request it received and every reply it sent, each clean
    assert frames == 2 * summary["frames_in"]
    directions = tshark_util.run(tshark, pcap, "-T", "fields", "-e", "frame.p2p_dir").split()
    assert directions.count("0") == directions.count("1") == summary["frames_in"]
    print(
        f"\n{nodes} x {size} B: config_init {doc['config_init_s']} s, config_map "
        f"{doc['config_map_s']} s, cycle {doc['cycle_us']} us, {distinct} samples seen, "
        f"{frames} frames captured, chain processing {summary['process_us_median']} us median"
    )


VENDOR_ID, REVISION = 0x534B494E, 0x00010000  # the README's identity of a skin patch
# SDO abort codes, ETG.1000.6 Table 41
ABORT_NO_OBJECT, ABORT_NO_SUBINDEX, ABORT_READ_ONLY = 0x06020000, 0x06090011, 0x06010002
ABORT_LENGTH, ABORT_VALUE_TOO_LOW = 0x06070010, 0x06090032


def promised_txpdos(size: int) -> dict[int, list[int]]:
    """The mapping the README promises, by hand: TxPDO 0x1A00 + t maps taxels 0x6000 + t:1..12,
    8 bits each, as 0x1A00:n values (index << 16 | subindex << 8 | bits)."""
    out: dict[int, list[int]] = {}
    for i in range(size):
        t, k = divmod(i, 12)
        out.setdefault(0x1A00 + t, []).append((0x6000 + t) << 16 | (k + 1) << 8 | 8)
    return out


def check_coe(coe: dict[str, Any], size: int) -> None:
    """What SOEM read and wrote over SDO, against the SII it read and the spec's codes."""
    assert coe["vendor_id"] == VENDOR_ID
    assert coe["identity"] == [VENDOR_ID, 0x00010000 + size, REVISION, 1]
    assert coe["device_name"] == f"SkinPatch{size}"
    promised = promised_txpdos(size)
    sii = {int(k): v for k, v in coe["sii_txpdos"].items()}
    assert sii == {k: [3, v] for k, v in promised.items()}  # SII: every TxPDO on SM3
    assert coe["assign"] == list(promised)  # 0x1C13 assigns what the SII puts on SM3
    assert {int(k): v for k, v in coe["mappings"].items()} == promised
    n = len(promised)  # complete access: subindex 0 as 16 bits, then the entries
    assert bytes.fromhex(coe["assign_ca"]) == bytes([n, 0]) + b"".join(
        p.to_bytes(2, "little") for p in promised
    )
    assert coe["sm_types"] == [1, 2, 3, 4]  # mailbox out, mailbox in, outputs, inputs
    assert coe["abort_unknown_object"] == ABORT_NO_OBJECT
    assert coe["abort_unknown_subindex"] == ABORT_NO_SUBINDEX
    assert coe["abort_read_only"] == ABORT_READ_ONLY
    assert coe["abort_length"] == ABORT_LENGTH
    assert coe["abort_range"] == ABORT_VALUE_TOO_LOW
    assert coe["sampling_period_us"] == 2000  # written in PRE-OP, read back
    od = {o[0]: o[1:] for o in coe["od"]}  # SDO information: index -> name, code, entries
    expected = {0x1000, 0x1001, 0x1008, 0x1009, 0x100A, 0x1018, 0x1C00, 0x1C12, 0x1C13, 0x8000}
    expected |= set(promised) | {0x6000 + t for t in range(len(promised))}
    assert set(od) == expected
    assert od[0x1018] == ["Identity", 9, 5]  # RECORD, subindices 0-4
    assert od[0x1C13][1:] == [8, n + 1]  # ARRAY
    assert od[0x1A00][1:] == [9, len(promised[0x1A00]) + 1]


def tshark_fields(tshark: str, path: Path, display: str, *names: str) -> list[list[str]]:
    out = tshark_util.run(
        tshark, path, "-Y", display, "-T", "fields", *(a for n in names for a in ("-e", n))
    )
    return [line.split("\t") for line in out.splitlines()]


def check_coe_capture(tshark: str, path: Path, coe: dict[str, Any]) -> None:
    """tshark decodes the mailbox traffic as the SDO exchange SOEM reported."""
    rows = tshark_fields(
        tshark,
        path,
        "ecat_mailbox",
        *("ecat.cmd", "ecat.cnt", "ecat.ado", "ecat_mailbox.type", "ecat_mailbox.counter"),
        *("ecat_mailbox.coe.type", "ecat_mailbox.coe.sdoidx", "ecat_mailbox.coe.sdosub"),
        *("ecat_mailbox.coe.sdodata", "ecat_mailbox.coe.abortcode"),
    )
    assert rows
    # every mailbox write the slaves accepted and every read of SM1 decodes as a mailbox
    for cmd, ado in (("0x05", "0x1000"), ("0x04", "0x1080")):
        accepted = tshark_fields(
            tshark, path, f"ecat.cmd == {cmd} && ecat.ado == {ado} && ecat.cnt == 1", "ecat.cmd"
        )
        assert len(accepted) == sum(1 for r in rows if r[0] == cmd and r[1] == "1")
    last: tuple[int, int] | None = None  # the SDO request the slave accepted last
    uploads: dict[tuple[int, int], str] = {}
    aborts: dict[tuple[int, int], int] = {}
    for cmd, wkc, ado, kind, counter, service, idx, sub, data, abort in rows:
        assert kind == "3" and 1 <= int(counter) <= 7  # CoE, counted
        if cmd == "0x05" and wkc == "1":  # a request the slave accepted (FPWR into SM0)
            assert int(ado, 16) == 0x1000
            if service == "2" and idx:
                last = (int(idx, 16), int(sub, 16))
        elif cmd == "0x04":  # an answer read from SM1
            assert int(ado, 16) == 0x1080 and wkc == "1"
            assert last is not None
            if abort:  # tshark shows an abort's code, not its index
                aborts[last] = int(abort, 16)
            elif service == "3" and idx:
                assert (int(idx, 16), int(sub, 16)) == last  # the answer to the last request
                if data:
                    uploads[last] = data
    for k, value in enumerate(coe["identity"], start=1):
        assert int(uploads[0x1018, k], 16) == value
    assert int(uploads[0x1C13, 0], 16) == len(coe["assign"])
    for k, pdo in enumerate(coe["assign"], start=1):
        assert int(uploads[0x1C13, k], 16) == pdo
    assert aborts[0x2000, 0] == ABORT_NO_OBJECT
    assert aborts[0x1018, 9] == ABORT_NO_SUBINDEX
    assert aborts[0x1018, 1] == ABORT_READ_ONLY
    assert aborts[0x8000, 2] == ABORT_LENGTH


@pytest.mark.tshark
def test_pysoem_reassigns_pdos_in_preop(net: VethPair, tshark: str, tmp_path: Path) -> None:
    """0x1C13 rewritten in PRE-OP (8 of 16 triangles): SOEM's config_map maps half the bytes and
    the slaves deliver the first 8 triangles of every sample."""
    nodes, size, triangles = 21, 192, 8
    inputs = tmp_path / "inputs.bin"
    with serving(net, nodes, size) as server:
        doc = run_soem(net, inputs, 1000, "--assign-triangles", str(triangles))
    assert server["rc"] == 0, server["stderr"]
    take = triangles * 12
    assert doc["iomap_bytes"] == nodes * take
    assert doc["expected_wkc"] == nodes
    assert (doc["safeop"], doc["op"], doc["al_status_codes"]) == (4, 8, [0])
    assert doc["wkc"] == [nodes] * 1000
    data = np.fromfile(inputs, dtype=np.uint8)
    assert data.size == 1000 * nodes * take
    assert check_taxels(data, nodes, size, take, seed=SEED, samples=SAMPLES) > 1


@pytest.mark.tshark
def test_pysoem_distributed_clocks(net: VethPair, tshark: str, tmp_path: Path) -> None:
    """config_dc finds DC on every patch, dc_sync(True, 1 ms) starts SYNC0, and after 1,000
    cycles (each with SOEM's FRMW of the reference clock) the system time difference (0x092C)
    of every patch that follows the reference is below 100 ns, although each patch's clock
    drifts by up to 25 ppm."""
    nodes, size = 21, 192
    pcap = tmp_path / "dc.pcapng"
    with serving(net, nodes, size, pcap) as server:
        doc = run_soem(net, tmp_path / "inputs.bin", 1000, "--dc")
    assert server["rc"] == 0, server["stderr"]
    assert doc["config_dc"] == 1  # SOEM: TRUE, DC slaves found
    # SOEM wrote a propagation delay to every patch but the reference: one ESC pass and cable
    # (WIRE: 540.05 ns) per hop, measured from the latched receive times
    delays = doc["dc_delays"]
    assert delays[0] == 0
    assert all(abs(d - 540 * p) <= p + 1 for p, d in enumerate(delays)), delays
    assert doc["dc_activation"] == [3] * nodes  # cyclic operation + SYNC0
    assert doc["wkc"] == [nodes] * 1000
    # every patch compares its clock with the reference's; patch 0, the reference, which SOEM's
    # FRMW reads and so never compares, reads 0: SOEM's write of 0x0930 after its BWR 0x0910 =
    # 0 at start-up reset the difference (datasheet II 0x0930)
    assert doc["dc_diff_ns"][0] == 0, doc["dc_diff_ns"]
    assert all(abs(d) < 100 for d in doc["dc_diff_ns"]), doc["dc_diff_ns"]
    assert doc["dc_sync0_status"] == [1] * nodes  # pulses fired since dc_sync
    assert doc["dc_time"] > 0
    check_capture(tshark, pcap)  # clean: no malformed frame, no warning but SOEM's source MAC
    frmw = tshark_util.run(tshark, pcap, "-Y", "ecat.cmd == 14 && ecat.ado == 0x0910")
    assert len(frmw.splitlines()) >= 2000  # the FRMW of every cycle, out and back
    print(f"\nDC: differences after 1,000 cycles {doc['dc_diff_ns']} ns")


@pytest.mark.parametrize("serve_options", [[], ["--no-mailbox"]])
def test_hostile_bench_configures_the_patches_serve_builds(serve_options: list[str]) -> None:
    """benchmarks/bench_serve_hostile.py --live ends with a reset, the configuration and an LRD
    that must return every patch's inputs. It once configured mailbox-less patches (inputs on
    SM0) while serve builds CoE patches by default (SM0/SM1 mailboxes, inputs on SM3), so its LRD
    answered with working counter 0 even without a single hostile frame. In process, on the
    chain serve builds from these options (deterministic, no network): every final frame is
    answered, the patches reach OP, the LRD returns the published rows with wkc = nodes; an
    answer of the same length to another frame is not taken for the LRD's answer."""
    from skinframes_cli import build_parser

    bench = load_benchmark("bench_serve_hostile")
    nodes, size = 160, 8
    args = build_parser().parse_args(
        [
            "serve",
            "ecat",
            "--iface",
            "x",
            "--nodes",
            str(nodes),
            "--bytes",
            str(size),
            *serve_options,
        ]
    )
    mailbox = not args.no_mailbox
    chain = EcatChain.skin(nodes, size, mailbox=mailbox)  # as skinframes_cli/serve.py does
    *setup, lrd = bench.final_frames(nodes, size, mailbox)
    for frame in setup:
        back = chain.process_frame(frame)
        assert back is not None and bench.is_answer(frame, back)
    assert {dev.al_status for dev in chain.devices} == {AlState.OP}
    rows = taxel.sample_payloads(nodes, 1, size, seed=5)[0]
    chain.publish(rows)
    back = chain.process_frame(lrd)
    assert back is not None and bench.is_answer(lrd, back)
    (d,) = ethercat.decode(back[14:])[0].datagrams
    assert d.wkc == nodes  # hand-computed: one read per patch (ETG.1000.4 Table 14, LRD)
    assert d.data == rows.tobytes()
    stale = ethercat.frame(  # same length, another index: a late answer to an earlier LRD
        EcatFrame((Datagram.logical(Command.LRD, 0, bytes(nodes * size), idx=0),))
    ).to_bytes()
    assert len(stale) == len(lrd) and not bench.is_answer(lrd, chain.process_frame(stale))


def test_serve_survives_hostile_frames_and_answers_a_configured_read(net: VethPair) -> None:
    """A CI-sized version of issue 11's acceptance run (benchmarks/bench_serve_hostile.py
    --live sends 100,000): hostile frames to 160 patches, then a master resets and configures
    the line and an LRD returns published samples of every patch."""
    nodes, size = 160, 8
    answered = 0
    bench = load_benchmark(
        "bench_serve_hostile"
    )  # its final frames and answer matching, as --live uses them
    with serving(net, nodes, size) as server, netns_socket(net.master, net.netns) as sock:

        def exchange(frame: bytes) -> bytes | None:
            # every frame here must be answered: the long wait only slows a busy machine
            sock.send(frame)
            deadline = time.monotonic() + 10.0
            while (left := deadline - time.monotonic()) > 0:
                if select.select([sock.fileno()], [], [], left)[0]:
                    while (back := sock.recv()) is not None:
                        if bench.is_answer(frame, back):
                            return back
            return None

        for frame in hostile_frames(1000, nodes=nodes, input_bytes=size, seed=7):
            sock.send(frame)  # answers (or none, for frames the line drops) are not awaited
        while select.select([sock.fileno()], [], [], 2.0)[0]:  # until serve fell quiet
            while sock.recv() is not None:
                answered += 1
        *setup, lrd = bench.final_frames(nodes, size, True)  # serve's patches have a mailbox
        unanswered = [i for i, frame in enumerate(setup) if exchange(frame) is None]
        back = exchange(lrd)
    assert server["rc"] == 0, server["stderr"]
    summary = server["summary"]
    assert summary["frames_in"] >= 1000 and summary["errors"] == 0, summary["error_messages"]
    assert unanswered == [], "reset and configuration frames without an answer"
    assert back is not None
    (d,) = ethercat.decode(back[14:])[0].datagrams
    assert d.wkc == nodes
    rows = np.frombuffer(d.data, dtype=np.uint8).reshape(nodes, size)
    candidates = samples_of_rows(rows, taxel.sample_payloads(nodes, SAMPLES, size, seed=SEED))
    assert set.intersection(*candidates), "one LRD frame carries one sample of every patch"
    print(f"\nhostile: {answered} answers, serve CPU max {summary['cpu_us_max']} us per frame")


@pytest.mark.tshark
def test_serve_pcap_keeps_the_wire_length_of_jumbo_frames(
    live: None, tshark: str, tmp_path: Path
) -> None:
    """Frames longer than 1522 bytes (jumbo, on a veth of MTU 65535) are received whole up to
    the capture's snap length, 65535: ``serve --pcap`` records each with its length on the wire
    as the original length (before, it read 1586 bytes and recorded 1586 as both); serve drops
    them (no EtherCAT frame is that long) and answers the BRD sent after them."""
    brd = ethercat.frame(EcatFrame((Datagram(Command.BRD, 0, 0x0130, bytes(2)),))).to_bytes()
    jumbo = [brd[:14] + bytes(n - 14) for n in (6000, 8000, 65535 + 14)]
    path = tmp_path / "serve.pcapng"
    with veth_netns(prefix="jumbo") as pair:
        for dev in (pair.master, pair.slave):
            live_util.in_netns(pair, "ip", "link", "set", dev, "mtu", "65535").check_returncode()
        with serving(pair, 4, 16, path) as server, netns_socket(pair.master, pair.netns) as sock:
            for frame in [*jumbo, brd]:
                sock.send(frame)
            deadline = time.monotonic() + 60.0  # the answer to the BRD: serve read all before it
            answer = None
            while answer is None and select.select([sock], [], [], deadline - time.monotonic())[0]:
                answer = sock.recv()
            assert answer is not None, "no answer to the BRD"
    assert server["rc"] == 0, server["stderr"]
    summary = server["summary"]
    assert (summary["frames_in"], summary["frames_out"], summary["dropped"]) == (4, 1, 3)
    assert summary["errors"] == 0
    rows = tshark_util.run(tshark, path, "-T", "fields", "-e", "frame.len", "-e", "frame.cap_len")
    sent = [(len(f), min(len(f), 65535)) for f in [*jumbo, brd]] + [(len(answer), len(answer))]
    assert [tuple(map(int, row.split())) for row in rows.splitlines()] == sent


def test_independent_master_over_the_wire(net: VethPair) -> None:
    nodes, size = 5, 192
    with serving(net, nodes, size) as server:
        done = subprocess.run(
            [
                *("ip", "netns", "exec", net.netns, sys.executable),
                *(str(TESTS / "mini_master.py"), net.master, str(nodes)),
            ],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
    assert server["rc"] == 0
    assert done.returncode == 0, done.stderr[-3000:]
    r = json.loads(done.stdout)
    assert (r["count"], r["esc_type"], r["name"]) == (nodes, 0x11, "SkinPatch192")
    assert r["identity"] == [[0x534B494E, 0x000100C0, 0x00010000, p + 1] for p in range(nodes)]
    assert (r["broadcast_serial_or"], r["broadcast_wkc"]) == (1 | 2 | 3 | 4 | 5, nodes)
    assert r["sm"] == [0x1100, size, 0x20, 1, 4]  # SM3 after the two 128-byte mailboxes
    assert (r["al_status_4"], r["al_status_8"], r["al_status_final"]) == ("0400", "0800", "0100")
    assert r["lrd_wkc"] == [nodes]
    payloads = taxel.sample_payloads(nodes, SAMPLES, size, seed=SEED)
    rows = np.frombuffer(bytes.fromhex(r["inputs"]), dtype=np.uint8).reshape(nodes, size)
    assert len(set(sample_of_rows(rows, payloads))) == 1  # one LRD frame: one sample


def test_serve_in_process_on_a_socket_opened_inside_the_namespace(net: VethPair) -> None:
    nodes, size = 3, 192
    chain = EcatChain.skin(nodes, size)
    feed = TaxelFeed(nodes, size, samples=8, seed=5, period_s=0.002)
    stop = threading.Event()
    stats: list[ServeStats] = []
    with netns_socket(net.slave, net.netns) as sock:
        worker = threading.Thread(target=lambda: stats.append(serve(chain, sock, stop, feed=feed)))
        worker.start()
        try:
            done = subprocess.run(
                [
                    *("ip", "netns", "exec", net.netns, sys.executable),
                    *(str(TESTS / "mini_master.py"), net.master, str(nodes)),
                ],
                cwd=ROOT,
                capture_output=True,
                text=True,
                timeout=120,
                check=False,
            )
        finally:
            stop.set()
            worker.join(30)
    assert done.returncode == 0, done.stderr[-3000:]
    rows = np.frombuffer(bytes.fromhex(json.loads(done.stdout)["inputs"]), dtype=np.uint8)
    k = sample_of_rows(rows.reshape(nodes, size), feed.payloads)
    assert len(set(k)) == 1
    (st,) = stats
    assert st.frames_in == st.frames_out > 50 and st.dropped == 0 and st.publications > 1


def test_serve_stops_cleanly_on_sigterm(net: VethPair) -> None:
    proc = subprocess.Popen(
        [
            *("ip", "netns", "exec", net.netns, sys.executable, "-m", "skinframes", "serve"),
            *("ecat", "--iface", net.slave, "--nodes", "2", "--bytes", "16"),
        ],
        cwd=ROOT,
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    read_line(proc.stderr, "serving", 60)
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0
    assert out.startswith("served 0 of 0 frames")


def test_serve_says_at_start_whether_the_escs_run_compiled(net: VethPair) -> None:
    """With SKINFRAMES_PURE=1 the ESCs run as Python whatever was compiled: the line serve
    prints once serving says so, and how to compile them; the summary agrees."""
    proc = subprocess.Popen(
        [
            *("ip", "netns", "exec", net.netns, sys.executable, "-m", "skinframes", "serve"),
            *("ecat", "--iface", net.slave, "--nodes", "2", "--bytes", "16", "--json"),
        ],
        cwd=ROOT,
        env={**ENV, "SKINFRAMES_PURE": "1"},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    line = read_line(proc.stderr, "serving", 60)
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=60)
    assert "the ESCs as Python (make compiles them); SIGINT/SIGTERM to stop" in line
    assert proc.returncode == 0 and json.loads(out)["compiled"] is False


NOBODY = ("setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "--inh-caps=-all")
NOBODY_PACKAGES = ("skinframes", "skinframes_cli", "emulator", "construct", "numpy", "tqdm")


def as_nobody(args: list[str], cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*NOBODY, *args],
        cwd=cwd,
        env={**env, "PYTHONDONTWRITEBYTECODE": "1"},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def readable_by_nobody(folder: Path) -> tuple[list[str], Path, dict[str, str]]:
    """An interpreter command, a working folder and an environment with which uid 65534
    imports the CLI: this checkout as it is when uid 65534 can read it, else copies of the
    packages it imports in ``folder`` (a checkout in a 0700 folder, e.g. a clone in root's
    home, where the venv cannot be read either)."""
    probe = ["-c", "import skinframes_cli.serve, emulator.live"]
    if as_nobody([sys.executable, *probe], Path("/"), ENV).returncode == 0:
        return [sys.executable], ROOT, ENV
    python = os.path.realpath(sys.executable)  # the venv's interpreter is a link into it
    folder.chmod(0o755)
    for name in NOBODY_PACKAGES:
        spec = importlib.util.find_spec(name)
        assert spec is not None and spec.submodule_search_locations, name
        src = Path(next(iter(spec.submodule_search_locations)))
        shutil.copytree(src, folder / name, ignore=shutil.ignore_patterns("__pycache__"))
        libs = src.with_name(name + ".libs")  # numpy's bundled shared libraries
        if libs.is_dir():
            shutil.copytree(libs, folder / libs.name)
    for path in folder.rglob("*"):
        path.chmod(0o755 if path.is_dir() else 0o644)
    env = {**os.environ, "PYTHONPATH": str(folder)}
    done = as_nobody([python, "-S", *probe], folder, env)
    if done.returncode != 0:
        pytest.skip(f"uid 65534 cannot run {python} with copies of the packages: {done.stderr}")
    return [python, "-S"], folder, env


def test_serve_reports_a_missing_interface_and_missing_privileges(
    live: None, tmp_path_factory: pytest.TempPathFactory
) -> None:
    done = subprocess.run(
        [
            *(sys.executable, "-m", "skinframes", "serve", "ecat", "--iface", "skf-none0"),
            *("--nodes", "2", "--bytes", "16"),
        ],
        cwd=ROOT,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr == "skinframes: error: no network interface 'skf-none0'\n"
    if os.geteuid() != 0 or shutil.which("setpriv") is None:
        return
    folder = Path(tempfile.mkdtemp(prefix="skinframes-nobody-"))  # /tmp: others may enter
    try:
        python, cwd, env = readable_by_nobody(folder)
        done = as_nobody(
            [
                *(*python, "-m", "skinframes", "serve", "ecat", "--iface", "lo"),
                *("--nodes", "2", "--bytes", "16"),
            ],
            cwd,
            env,
        )
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("skinframes: error: opening a raw socket on 'lo' needs root")
    assert done.stderr.count("\n") == 1


NETNS_SCRIPT = """
import subprocess, sys, time
sys.path.insert(0, {root!r})
from emulator.live import veth_netns
with veth_netns() as net:
    child = subprocess.Popen(
        ["ip", "netns", "exec", net.netns, "sleep", "300"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    where = ["ip", "netns", "identify", str(child.pid)]
    while subprocess.run(where, capture_output=True, text=True).stdout.strip() != net.netns:
        time.sleep(0.01)  # until the child runs inside the namespace
    print(net.netns, child.pid, flush=True)
    {body}
"""


def start_netns_script(body: str) -> tuple[subprocess.Popen[str], str, int]:
    proc = subprocess.Popen(
        [sys.executable, "-c", NETNS_SCRIPT.format(root=str(ROOT), body=body)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    line = read_line(proc.stdout, "skinframes-", 30).split()
    return proc, line[0], int(line[1])


def gone(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as f:
            return f.read().rpartition(")")[2].split()[0] == "Z"
    except OSError:
        return True


@pytest.mark.parametrize("how", ["sigint", "sigterm", "exception"])
def test_netns_is_always_removed(live: None, how: str) -> None:
    body = "raise RuntimeError('boom')" if how == "exception" else "time.sleep(300)"
    proc, name, child = start_netns_script(body)
    assert name in netns_names() or how == "exception"
    if how != "exception":
        proc.send_signal(signal.SIGINT if how == "sigint" else signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    expected = {"sigint": "KeyboardInterrupt", "sigterm": "", "exception": "RuntimeError: boom"}
    assert expected[how] in err
    # SystemExit(143) from the SIGTERM handler; Python re-raises SIGINT after KeyboardInterrupt
    assert proc.returncode == {"sigint": -signal.SIGINT, "sigterm": 143, "exception": 1}[how]
    assert name not in netns_names()
    assert gone(child)  # the process left inside the namespace was ended


def test_netns_names_are_unique(live: None) -> None:
    with veth_netns() as a, veth_netns() as b:
        assert a.netns != b.netns
        assert {a.netns, b.netns} <= netns_names()
    assert not {a.netns, b.netns} & netns_names()
