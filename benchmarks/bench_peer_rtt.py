"""A pysoem master's process-data round trip: ``skinframes serve ecat`` next to KickCAT's simulator.

What is measured: the time of one ``send_processdata`` + ``receive_processdata`` of pysoem (the
Python binding of SOEM), back to back, against two emulated EtherCAT networks of ``--nodes``
slaves with ``--bytes`` input bytes each:

  serve    ``python -m skinframes serve ecat --nodes N --bytes B`` from this checkout (the project
           is installed editable in the venv); its startup line says whether its ESCs ran
           compiled (``make`` compiles them) and the benchmark prints it
  kickcat  KickCAT's C++ ``network_simulator`` with N slaves of a 16-byte input-only device that
           the benchmark derives from KickCAT's example ESI (``--kickcat-esi``, freedom-k64f.xml:
           TxPDO 0x1A00 becomes 4 x UDINT 0x6000..0x6003 on SM3, no RxPDO, CoE mailbox kept)

Both run in one private network namespace, each fresh for each run, on one end of a veth pair;
the master runs on the other end (this file with ``--master``, in a subprocess in the namespace):
config_init, config_map, SAFE-OP, OP, ``--warmup`` cycles, then ``--cycles`` round trips, each
timed with perf_counter_ns, counting those whose working counter is not the expected one. The
targets alternate over ``--rounds`` in one run (their order rotates each round), so that
whatever else loads the machine meets both. Printed per round and pooled over rounds: median
and p99 per target, the working-counter misses (must be 0), the CPU the target used while the
master measured, and the machine's load (nproc, loadavg). ``--json FILE`` keeps the results.

Needs root (a network namespace, raw sockets) and pysoem in this venv. Run from the repository
root, for example:

    sudo .venv/bin/python benchmarks/bench_peer_rtt.py --simulator SIM --kickcat-esi ESI
        [--rounds 5] [--cycles 2000] [--nodes 160] [--bytes 16] [--warmup 100] [--pin M,T]
        [--json FILE]

Without ``--simulator`` it measures serve alone, and says so. The derived ESI and the
simulator's JSON slave configuration go into a temporary folder that the benchmark makes and
removes.

Building the simulator from KickCAT's sources (fetched for this, never committed here; results
in benchmarks/README.md are from KickCAT f10386d), in a scratch directory ``$K``:

    apt-get install libtinyxml2-dev nlohmann-json3-dev
    git clone https://github.com/p-ranav/argparse $K/argparse-src
    cmake -S $K/argparse-src -B $K/argparse-build -DARGPARSE_BUILD_TESTS=OFF \\
        -DARGPARSE_BUILD_SAMPLES=OFF
    cmake --install $K/argparse-build --prefix $K/deps
    git clone https://github.com/leducp/KickCAT $K/src
    cmake -S $K/src -B $K/build -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=$K/deps \\
        -DBUILD_MASTER_EXAMPLES=OFF -DBUILD_SLAVE_EXAMPLES=OFF -DBUILD_TOOLS=OFF \\
        -DBUILD_SIMULATION=ON -DENABLE_ESI_PARSER=ON -DKICKCAT_INSTALL=OFF
    make -C $K/build network_simulator

then ``--simulator $K/build/simulation/network_simulator`` and
``--kickcat-esi $K/src/examples/slave/lan9252/freedom-k64f/nuttx/freedom-k64f.xml``. The
simulator buffers its stdout when it is not a terminal, so the benchmark runs it under
``stdbuf -oL`` to see its "Opening" line (it serves from then on). It polls its socket with
20 us sleeps, which sets a floor under its round trip; serve waits in select.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import secrets
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
TICK = os.sysconf("SC_CLK_TCK")
KICKCAT_BYTES = 16  # the derived device's inputs
START_S = 60  # a target that does not serve within this long has failed


# --- the master: runs in the namespace, prints one JSON line ------------------------------------


def master(iface: str, cycles: int, warmup: int, timeout_us: int) -> None:
    """pysoem: scan, map, OP, ``warmup`` cycles, then ``cycles`` timed round trips (ns)."""
    import pysoem  # type: ignore[import-untyped]

    t = pysoem.settings.timeouts
    t.ret, t.safe, t.eeprom, t.state = 50_000, 500_000, 500_000, 20_000_000
    m = pysoem.Master()
    m.open(iface)
    out: dict[str, Any] = {}
    try:
        out["slaves"] = m.config_init()
        s0 = m.slaves[0]
        out["slave0"] = {"man": s0.man, "id": s0.id, "name": s0.name}
        out["iomap_bytes"] = m.config_map()
        out["expected_wkc"] = m.expected_wkc
        m.state_check(pysoem.SAFEOP_STATE, 20_000_000)
        m.state = pysoem.OP_STATE
        m.write_state()
        for _ in range(400):
            m.send_processdata()
            m.receive_processdata(timeout_us)
            if m.state_check(pysoem.OP_STATE, 5_000) == pysoem.OP_STATE:
                break
        out["op"] = m.state_check(pysoem.OP_STATE, 20_000_000) == pysoem.OP_STATE
        for _ in range(warmup):
            m.send_processdata()
            m.receive_processdata(timeout_us)
        rtt: list[int] = []
        misses = 0
        pc, send, recv, exp = (
            time.perf_counter_ns,
            m.send_processdata,
            m.receive_processdata,
            m.expected_wkc,
        )
        for _ in range(cycles):
            c0 = pc()
            send()
            wkc = recv(timeout_us)
            rtt.append(pc() - c0)
            misses += wkc != exp
        out["wkc_misses"] = misses
        out["rtt_ns"] = rtt
        m.state = pysoem.INIT_STATE
        m.write_state()
    finally:
        m.close()
    print(json.dumps(out))


# --- the KickCAT device ------------------------------------------------------------------------


def derive_esi(src: Path, folder: Path) -> Path:
    """A 16-byte input-only device from KickCAT's freedom-k64f.xml in ``folder``; returns the
    simulator's JSON slave configuration that names it."""
    tree = ET.parse(src)
    dev = tree.getroot().find("Descriptions/Devices/Device")
    assert dev is not None
    objects = dev.find("Profile/Dictionary/Objects")
    assert objects is not None
    by_index = {(o.findtext("Index") or "").lower(): o for o in objects.findall("Object")}

    def set_text(node: ET.Element, path: str, text: str) -> None:
        found = node.find(path)
        assert found is not None, path
        found.text = text

    for idx in ("#x6000", "#x6001", "#x6002", "#x6003"):  # 4 x UDINT
        o = by_index[idx]
        set_text(o, "Type", "UDINT")
        set_text(o, "BitSize", "32")
        set_text(o, "Info/DefaultData", "00000000")
        set_text(o, "Name", "taxels_" + idx[-1])
    for idx in ("#x6004", "#x6005", "#x7000", "#x7001", "#x7002"):
        objects.remove(by_index[idx])
    tx_map = by_index["#x1a00"]
    subs = tx_map.findall("Info/SubItem")
    set_text(subs[0], "Info/DefaultData", "04")
    for k in range(1, 5):
        set_text(subs[k], "Info/DefaultData", f"200{k - 1}0060")  # 0x600k:00, 32 bits (LE)
    info = tx_map.find("Info")
    assert info is not None
    for s in subs[5:]:
        info.remove(s)
    set_text(tx_map, "BitSize", str(16 + 4 * 32))
    set_text(by_index["#x1c12"].findall("Info/SubItem")[0], "Info/DefaultData", "00")
    rx = dev.find("RxPdo")
    tx = dev.find("TxPdo")
    assert rx is not None and tx is not None
    dev.remove(rx)
    entries = tx.findall("Entry")
    for k, e in enumerate(entries[:4]):
        set_text(e, "BitLen", "32")
        set_text(e, "DataType", "UDINT")
        set_text(e, "Name", f"taxels_{k}")
    for e in entries[4:]:
        tx.remove(e)
    for sm in dev.findall("Sm"):
        if sm.text == "Outputs":
            sm.set("DefaultSize", "0")
        if sm.text == "Inputs":
            sm.set("DefaultSize", str(KICKCAT_BYTES))
    set_text(dev, "Name", "Patch16")
    esi = folder / "patch16.xml"
    tree.write(esi, encoding="utf-8", xml_declaration=True)
    config = folder / "patch16.json"
    config.write_text(json.dumps({"esi": esi.name}) + "\n")  # relative to the JSON's folder
    return config


# --- one run of one target ---------------------------------------------------------------------


def cpu_ticks(pid: int) -> int:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])  # utime + stime


def pinned(cpu: int | None) -> list[str]:
    """A command's prefix that keeps it, its threads and children on CPU ``cpu`` (None: free)."""
    return [] if cpu is None else ["taskset", "-c", str(cpu)]


def target_cmd(name: str, ns: str, args: argparse.Namespace, config: Path | None) -> list[str]:
    pre = ["ip", "netns", "exec", ns, *pinned(args.pin[1] if args.pin else None)]
    if name == "kickcat":
        assert config is not None
        return [
            *pre,
            "stdbuf",
            "-oL",
            args.simulator,
            "-i",
            "ecs0",
            "-s",
            *[str(config)] * args.nodes,
        ]
    return [*pre, sys.executable, "-m", "skinframes", "serve", "ecat", "--iface", "ecs0",
            "--nodes", str(args.nodes), "--bytes", str(args.bytes)]  # fmt: skip


def run_one(
    name: str, ns: str, args: argparse.Namespace, folder: Path, config: Path | None
) -> dict[str, Any]:
    ready = "Opening" if name == "kickcat" else "serving"
    log = folder / f"{name}.log"
    with open(log, "w") as f:
        proc = subprocess.Popen(
            target_cmd(name, ns, args, config), stdout=f, stderr=subprocess.STDOUT,
            cwd=ROOT if name == "serve" else folder, start_new_session=True,
        )  # fmt: skip
    out: dict[str, Any] = {"target": name}
    try:
        deadline = time.monotonic() + START_S
        while ready not in (text := log.read_text(errors="replace")):
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"{name} did not start:\n{text[-2000:]}")
            time.sleep(0.1)
        if name == "serve":
            line = next(x for x in text.splitlines() if "serving" in x)
            out["compiled"] = "the ESCs compiled" in line
        time.sleep(0.5)
        # `ip netns exec` and stdbuf exec the command: proc.pid is the emulator itself
        c0, w0, load0 = cpu_ticks(proc.pid), time.monotonic(), os.getloadavg()
        done = subprocess.run(
            ["ip", "netns", "exec", ns, *pinned(args.pin[0] if args.pin else None),
             sys.executable, __file__, "--master", "ecm0",
             "--cycles", str(args.cycles), "--warmup", str(args.warmup)],
            capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        c1, w1 = cpu_ticks(proc.pid), time.monotonic()
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    if done.returncode != 0 or not done.stdout.strip():
        raise RuntimeError(f"pysoem against {name} failed:\n{done.stderr[-3000:]}")
    out.update(json.loads(done.stdout.splitlines()[-1]))
    out["target_cpu_pct"] = round(100 * (c1 - c0) / TICK / (w1 - w0), 1)
    out["load1_before"] = load0[0]
    return out


def stats(rtt_ns: list[int]) -> dict[str, float]:
    us = sorted(x / 1000 for x in rtt_ns)
    return {
        "n": len(us),
        "median": round(statistics.median(us), 1),
        "p99": round(us[min(len(us) - 1, int(0.99 * len(us)))], 1),
        "max": round(us[-1], 1),
    }


def netns(ns: str) -> None:
    """A namespace with the veth pair ecm0 (master) <-> ecs0 (target), both up."""

    def run(*a: str) -> None:
        subprocess.run(["ip", *a], check=True)

    run("netns", "add", ns)
    run("-n", ns, "link", "add", "ecm0", "type", "veth", "peer", "name", "ecs0")
    for dev in ("lo", "ecm0", "ecs0"):
        run("-n", ns, "link", "set", dev, "up")
    subprocess.run(
        ["ip", "netns", "exec", ns, "sysctl", "-q", "-w", "net.ipv6.conf.all.disable_ipv6=1"],
        check=False,
    )  # no router solicitations on the wire


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--simulator", metavar="PATH", help="KickCAT's built network_simulator")
    parser.add_argument(
        "--kickcat-esi",
        metavar="PATH",
        help="KickCAT's example freedom-k64f.xml (with --simulator)",
    )
    parser.add_argument("--rounds", type=int, default=5, help="default 5")
    parser.add_argument(
        "--cycles", type=int, default=2000, help="timed round trips a run (default 2000)"
    )
    parser.add_argument(
        "--warmup", type=int, default=100, help="untimed cycles first (default 100)"
    )
    parser.add_argument("--nodes", type=int, default=160, help="slaves (default 160)")
    parser.add_argument("--bytes", type=int, default=16, help="input bytes a slave (default 16)")
    parser.add_argument(
        "--pin",
        metavar="M,T",
        help="run the master on CPU M and the target on CPU T (taskset), e.g. 0,1; default: "
        "wherever the kernel puts them",
    )
    parser.add_argument("--json", metavar="FILE", help="write the results here")
    parser.add_argument("--master", metavar="IFACE", help=argparse.SUPPRESS)
    parser.add_argument("--timeout-us", type=int, default=100_000, help=argparse.SUPPRESS)
    args = parser.parse_args()
    for name in ("rounds", "cycles", "nodes", "bytes"):
        if getattr(args, name) < 1:
            parser.error(f"--{name} must be at least 1")
    if args.warmup < 0:
        parser.error("--warmup must not be negative")
    if args.pin is not None:
        cpus = sorted(os.sched_getaffinity(0))
        try:
            args.pin = [int(x) for x in args.pin.split(",")]
        except ValueError:
            parser.error(f"--pin {args.pin!r}: two CPU numbers, e.g. 0,1")
        if len(args.pin) != 2 or args.pin[0] == args.pin[1] or not set(args.pin) <= set(cpus):
            parser.error(f"--pin: two different CPUs of this machine's {cpus}")
        if shutil.which("taskset") is None:
            parser.error("--pin needs taskset (util-linux)")
    if args.master:
        master(args.master, args.cycles, args.warmup, args.timeout_us)
        return
    if args.simulator:
        if not os.access(args.simulator, os.X_OK) or not Path(args.simulator).is_file():
            parser.error(f"--simulator {args.simulator!r} is not an executable file")
        if not args.kickcat_esi:
            parser.error("--simulator needs --kickcat-esi (KickCAT's freedom-k64f.xml)")
        if not Path(args.kickcat_esi).is_file():
            parser.error(f"--kickcat-esi {args.kickcat_esi!r} is not a file")
        if args.bytes != KICKCAT_BYTES:
            parser.error(f"the KickCAT device has {KICKCAT_BYTES} input bytes; --bytes must be 16")
        if shutil.which("stdbuf") is None:
            parser.error("stdbuf (coreutils) not found; the simulator runs under stdbuf -oL")
    elif args.kickcat_esi:
        parser.error("--kickcat-esi only goes with --simulator")
    if os.geteuid() != 0:
        parser.error("needs root (a network namespace and raw sockets): run it with sudo")
    if importlib.util.find_spec("pysoem") is None:
        parser.error(f"pysoem is not installed in {sys.prefix}")
    if shutil.which("ip") is None:
        parser.error("the ip command (iproute2) is not found")
    targets = ["kickcat", "serve"] if args.simulator else ["serve"]
    if not args.simulator:
        print("no --simulator: measuring serve alone", flush=True)
    ns = f"peerrtt-{os.getpid()}-{secrets.token_hex(2)}"
    results: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="bench_peer_rtt-") as tmp:
        folder = Path(tmp)
        config = derive_esi(Path(args.kickcat_esi), folder) if args.simulator else None
        netns(ns)
        try:
            print(
                f"nproc {os.cpu_count()}, loadavg {os.getloadavg()}, {args.nodes} slaves x "
                f"{args.bytes} B, {args.cycles} cycles a run, {args.rounds} rounds, "
                + (
                    f"master on CPU {args.pin[0]}, target on CPU {args.pin[1]}"
                    if args.pin
                    else "not pinned"
                ),
                flush=True,
            )
            print(
                f"{'round':>5} {'target':<16} {'median':>8} {'p99':>8} {'max':>8} "
                f"{'wkc!':>5} {'cpu%':>6} {'load1':>6}",
                flush=True,
            )
            for r in range(args.rounds):
                for name in targets[r % len(targets) :] + targets[: r % len(targets)]:
                    res = run_one(name, ns, args, folder, config)
                    res["round"] = r
                    results.append(res)
                    s = stats(res["rtt_ns"])
                    print(
                        f"{r:>5} {label(res):<16} {s['median']:>8} {s['p99']:>8} {s['max']:>8} "
                        f"{res['wkc_misses']:>5} {res['target_cpu_pct']:>6} "
                        f"{res['load1_before']:>6.2f}",
                        flush=True,
                    )
        except (RuntimeError, subprocess.TimeoutExpired) as e:
            print(f"error: {e}", file=sys.stderr)
            sys.exit(1)
        finally:
            subprocess.run(["ip", "netns", "del", ns], check=False)
    print("pooled over rounds (us):")
    summary: dict[str, dict[str, Any]] = {}
    for name in targets:
        runs = [x for x in results if x["target"] == name]
        pool: dict[str, Any] = dict(stats([v for x in runs for v in x["rtt_ns"]]))
        summary[name] = pool
        pool["wkc_misses"] = sum(x["wkc_misses"] for x in runs)
        pool["run_medians"] = [stats(x["rtt_ns"])["median"] for x in runs]
        print(
            f"  {label(runs[0]):<16} median {pool['median']:>7}  p99 {pool['p99']:>7}  "
            f"max {pool['max']:>8}  wkc misses {pool['wkc_misses']}  run medians {pool['run_medians']}"
        )
    misses = sum(x["wkc_misses"] for x in results)
    print(f"working-counter misses: {misses}" + (" (ok)" if misses == 0 else " (NOT ok)"))
    print(f"nproc {os.cpu_count()}, loadavg after {os.getloadavg()}")
    if args.json:
        for x in results:
            x.pop("rtt_ns", None)
        Path(args.json).write_text(json.dumps({"summary": summary, "runs": results}, indent=1))
    if misses:
        sys.exit(1)


def label(res: dict[str, Any]) -> str:
    if res["target"] != "serve":
        return str(res["target"])
    return "serve compiled" if res["compiled"] else "serve as Python"


if __name__ == "__main__":
    main()
