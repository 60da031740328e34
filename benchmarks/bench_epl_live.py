"""The real openPOWERLINK MN with its shipped CDC against ``skinframes serve epl`` on veth.

Issue 40's acceptance, measured: openPOWERLINK V2.7.2's console MN (the kit in
../shared/tools/openpowerlink, ``build`` and ``run-node``) with the kit's shipped ``mnobd.cdc``
(CNs 1, 32 and 110, 50 ms cycle, PRes timeout 0x1F92 = 200 us, asynchronous slot 500 us)
boots ``serve epl --nodes 3 --node-ids 1,32,110`` over a veth pair in a private network
namespace. Printed per run:

- the time from the MN's start until its log reports the last CN OPERATIONAL (the issue asks
  for 40 s at most);
- per CN, the share of the cycles afterwards (SoC to SoC, last partial cycle left out) whose
  PRes from that CN the capture holds before the MN's next frame, i.e. within the PRes timeout
  (the issue asks for 90 % at least);
- per CN, PReq -> PRes as the MN's end of the veth sees them (dumpcap there: median, p99, max
  in us), and as serve saw them in its own record (receipt of the PReq to the send of the
  PRes, host clock);
- the machine's load (nproc, loadavg) before the run.

Nothing is asserted: the figures depend on the machine and its load. ``--rt-priority P`` runs
serve under SCHED_FIFO (as the MN and openPOWERLINK's own CN run), ``--seconds S`` how long the
cycles run after OPERATIONAL (default 20), ``--runs N`` repeats, ``--json FILE`` keeps the
figures. Needs root. Run from the repository root:

    sudo .venv/bin/python benchmarks/bench_epl_live.py [--runs 3] [--seconds 20] [--rt-priority 20]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from emulator.live import veth_netns  # noqa: E402
from skinframes import read_capture  # noqa: E402

KIT = Path(os.environ.get("OPENPOWERLINK_KIT", ROOT.parent / "shared" / "tools" / "openpowerlink"))
IDS = (1, 32, 110)  # the shipped CDC's CNs
BOOT_LIMIT_S = 120.0  # give up waiting for OPERATIONAL after this
SOC, PREQ, PRES = 0x01, 0x03, 0x04  # DS 301 Table 23 MessageType
OPERATIONAL = 0xFD


def operational(log: Path) -> set[int]:
    text = log.read_text(errors="replace") if log.exists() else ""
    pattern = r"Node=\s*(\d+), NmtNodeEventNmtState State:NmtCsOperational"
    return {int(n) for n in re.findall(pattern, text)}


def frames(path: Path) -> list[tuple[int, bytes]]:
    """(time ns, bytes) of each EPL frame of a capture."""
    return [(r.time_ns, r.data) for r in read_capture(path) if r.data[12:14] == b"\x88\xab"]


def responses_us(records: list[tuple[int, bytes]], since_ns: int) -> dict[int, list[float]]:
    """Per CN: PReq -> its PRes (us), for the PRes that came before the MN's next frame."""
    out: dict[int, list[float]] = {n: [] for n in IDS}
    polled: tuple[int, int] | None = None
    for t, f in records:
        if t < since_ns:
            continue
        mtype = f[14]
        if mtype == PREQ:
            polled = (f[15], t)
        elif mtype == PRES and polled is not None and f[16] == polled[0]:
            out.setdefault(f[16], []).append((t - polled[1]) / 1000)
            polled = None
        elif mtype != PRES:
            polled = None  # the MN moved on: a PRes after this is a miss
    return out


def presence(records: list[tuple[int, bytes]], since_ns: int) -> dict[int, float]:
    """Per CN: the % of cycles after ``since_ns`` with its PRes answering its PReq in time."""
    cycles: list[set[int]] = []
    polled = None
    for t, f in records:
        if t < since_ns:
            continue
        mtype = f[14]
        if mtype == SOC:
            cycles.append(set())
        elif not cycles:
            continue
        if mtype == PREQ:
            polled = f[15]
        elif mtype == PRES and polled == f[16] and f[17] == OPERATIONAL:
            cycles[-1].add(f[16])
            polled = None
        elif mtype != PRES:
            polled = None
    cycles = cycles[:-1]  # the last one may be cut short by the end of the capture
    return {n: 100.0 * sum(n in c for c in cycles) / max(1, len(cycles)) for n in IDS}


def pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return round(ordered[min(len(ordered) - 1, int(q * len(ordered)))], 1) if ordered else 0.0


def one_run(seconds: float, rt_priority: int | None, work: Path) -> dict[str, Any]:
    wire, served, log = work / "wire.pcapng", work / "serve.pcapng", work / "mn.log"
    for p in (wire, served, log):
        p.unlink(missing_ok=True)
    load = os.getloadavg()
    with veth_netns(master="eplbm0", slave="eplbc0", prefix="eplbench") as net:
        dumpcap = subprocess.Popen(
            ["ip", "netns", "exec", net.netns, "dumpcap", "-q", "-i", net.master, "-w", str(wire)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        serve_cmd = [
            *("ip", "netns", "exec", net.netns, sys.executable, "-m", "skinframes", "serve"),
            *("epl", "--iface", net.slave, "--nodes", "3", "--node-ids", "1,32,110"),
            *("--bytes", "24", "--pcap", str(served), "--json"),
            *(() if rt_priority is None else ("--rt-priority", str(rt_priority))),
        ]
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        serve = subprocess.Popen(serve_cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, text=True)
        time.sleep(1.5)
        started = time.monotonic()
        mn = subprocess.Popen(
            [str(KIT / "run-node"), "mn", net.master, "--netns", net.netns, "--log", str(log)]
        )
        boot_s = None
        while time.monotonic() - started < BOOT_LIMIT_S and mn.poll() is None:
            if operational(log) >= set(IDS):
                boot_s = time.monotonic() - started
                break
            time.sleep(0.1)
        op_wall_ns = time.time_ns()
        if boot_s is not None:
            time.sleep(seconds)
        serve.send_signal(signal.SIGINT)
        out, _ = serve.communicate(timeout=60)
        mn.terminate()
        mn.wait(timeout=30)
        dumpcap.send_signal(signal.SIGINT)
        dumpcap.wait(timeout=30)
    since = op_wall_ns + 100_000_000  # from 0.1 s after the log said OPERATIONAL
    wire_records, served_records = frames(wire), frames(served)
    wire_us, served_us = responses_us(wire_records, since), responses_us(served_records, since)
    summary = json.loads(out) if out.strip() else {}
    return {
        "loadavg": load,
        "operational_after_s": None if boot_s is None else round(boot_s, 1),
        "presence_pct": presence(wire_records, since),
        "wire_us": {
            n: (pct(v, 0.5), pct(v, 0.99), pct(v, 1.0), len(v)) for n, v in wire_us.items()
        },
        "serve_us": {
            n: (pct(v, 0.5), pct(v, 0.99), pct(v, 1.0), len(v)) for n, v in served_us.items()
        },
        "serve_states": [cn["state"] for cn in summary.get("cns", [])],
    }


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=1)
    p.add_argument("--seconds", type=float, default=20.0)
    p.add_argument("--rt-priority", type=int)
    p.add_argument("--json", type=Path)
    args = p.parse_args()
    if os.geteuid() != 0:
        print("bench_epl_live: needs root (network namespaces, raw sockets)", file=sys.stderr)
        return 2
    subprocess.run([str(KIT / "build")], check=True, stdout=subprocess.DEVNULL)
    print(
        f"nproc {os.cpu_count()}, serve {'SCHED_FIFO ' + str(args.rt_priority) if args.rt_priority else 'SCHED_OTHER'}"
    )
    results = []
    with tempfile.TemporaryDirectory(prefix="bench_epl_live.") as tmp:
        for run in range(args.runs):
            r = one_run(args.seconds, args.rt_priority, Path(tmp))
            results.append(r)
            print(
                f"run {run + 1}: loadavg {r['loadavg'][0]:.2f}; OPERATIONAL after "
                f"{r['operational_after_s']} s; serve's CNs at the end {r['serve_states']}"
            )
            for n in IDS:
                w, s = r["wire_us"][n], r["serve_us"][n]
                print(
                    f"  CN {n:3d}: PRes in {r['presence_pct'][n]:5.1f} % of cycles; PReq->PRes "
                    f"on the wire median {w[0]} us, p99 {w[1]} us, max {w[2]} us (n {w[3]}); "
                    f"in serve median {s[0]} us, p99 {s[1]} us, max {s[2]} us"
                )
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
