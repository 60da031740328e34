"""CPU per frame of the emulated chain under hostile traffic (issue 11: at most 2 ms at 160 slaves).

1. In process (default): ``--frames`` seeded hostile frames (:func:`emulator.esc.hostile.
   hostile_frames`: register writes aimed at FMMU, SM, AL and EEPROM registers, random commands,
   logical accesses, mutated configuration frames) through a configured chain of ``--nodes``
   patches, with a master's reset (:func:`emulator.esc.hostile.master_reset_frames`) every
   ``--reset-every`` frames, so that loops the hostile frames closed open again and every frame
   keeps meeting all slaves; each hostile frame's CPU time (this thread's clock) is measured. Printed: median, p99 and
   maximum, frames above 2 ms, the costliest frames' datagrams, and for reference the CPU of an
   ordinary LRD of the whole process image in the same run. Afterwards a master resets and
   configures the line again and an LRD must return every patch's inputs.
2. ``--live``: the same frames sent to ``skinframes serve ecat --nodes N`` over a veth pair in a
   private network namespace (needs root), one at a time (the next after the answer, or after
   ``--timeout-ms`` for a frame the chain drops); then, once late answers stopped coming, the
   reset, the configuration and an LRD whose rows must be one published sample (a sample index
   common to all rows: a short row may equal several samples of its patch); serve's own
   summary (frames it could not process, its maximum CPU per frame) is printed.

    python benchmarks/bench_serve_hostile.py [--nodes 160] [--frames 10000] [--live]
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import json
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import numpy.typing as npt

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from emulator.esc.chain import EcatChain, configure_frames  # noqa: E402
from emulator.esc.hostile import hostile_frames, master_reset_frames  # noqa: E402
from emulator.esc.sii import SlaveInfo  # noqa: E402
from skinframes import ethercat, taxel  # noqa: E402
from skinframes.ethercat import Command, Datagram, EcatFrame  # noqa: E402

BUDGET_US = 2000.0
SEED, SAMPLES = 11, 16


def lrd_frame(nodes: int, size: int) -> bytes:
    return ethercat.frame(
        EcatFrame((Datagram.logical(Command.LRD, 0, bytes(nodes * size)),))
    ).to_bytes()


def one_sample(rows: npt.NDArray[np.uint8], payloads: npt.NDArray[np.uint8]) -> set[int]:
    """The published samples k that every slave's row equals (``payloads[k, slave]``).

    A short row may equal several samples of its patch (8 bytes of 5 levels collide now and
    then), so each row is matched to all its candidates; one LRD frame carries one sample of
    every patch, so a correct answer has at least one sample common to all rows.
    """
    common = set(range(payloads.shape[0]))
    for p, row in enumerate(rows):
        common &= {int(k) for k in np.flatnonzero((payloads[:, p] == row).all(axis=1))}
    return common


def describe(frame: bytes) -> str:
    try:
        ecat, _, _ = ethercat.decode(frame[14:], strict=False)
    except ethercat.DecodeError:
        return "malformed"
    return " ".join(f"{int(d.cmd)}@{d.ado:#06x}+{len(d.data)}" for d in ecat.datagrams)


def with_resets(frames: int, nodes: int, size: int, seed: int, every: int) -> Iterator[bytes]:
    """The hostile frames, and the master's reset frames after every ``every`` of them."""
    reset = master_reset_frames(nodes)
    for i, frame in enumerate(hostile_frames(frames, nodes=nodes, input_bytes=size, seed=seed)):
        yield frame
        if every and i % every == every - 1:
            yield from reset


def in_process(nodes: int, size: int, frames: int, seed: int, every: int) -> None:
    chain = EcatChain.configured(nodes, size)
    gc.collect()
    gc.freeze()  # as serve does (emulator.live.serve): no collection walks the chain per frame
    cpu = time.thread_time_ns
    ref = lrd_frame(nodes, size)
    ref_us = []
    for _ in range(200):
        c0 = cpu()
        chain.process_frame(ref)
        ref_us.append((cpu() - c0) / 1e3)
    costs: list[tuple[float, int, bytes]] = []
    for i, frame in enumerate(with_resets(frames, nodes, size, seed, every)):
        c0 = cpu()
        chain.process_frame(frame)
        costs.append(((cpu() - c0) / 1e3, i, frame))
    us = np.array([c[0] for c in costs])
    ref_median = float(np.median(ref_us))
    print(
        f"in process: {frames} hostile frames (master reset every {every}), "
        f"{nodes} slaves x {size} bytes"
    )
    print(
        f"  CPU per frame: median {np.median(us):.0f} us, p99 {np.percentile(us, 99):.0f} us, "
        f"max {us.max():.0f} us; {int((us > BUDGET_US).sum())} frames above {BUDGET_US:.0f} us"
    )
    print(
        f"  reference: one LRD of the whole image {ref_median:.0f} us; max / reference "
        f"{us.max() / ref_median:.1f}"
    )
    for c, i, frame in sorted(costs, reverse=True)[:5]:
        print(f"  frame {i}: {c:.0f} us  {describe(frame)}")
    for frame in master_reset_frames(nodes) + configure_frames(chain.devices[0].info, nodes):
        chain.process_frame(frame)
    rows = taxel.sample_payloads(nodes, 1, size, seed=3)[0]
    chain.publish(rows)
    back = chain.process_frame(ref)
    assert back is not None
    ecat, _, _ = ethercat.decode(back[14:])
    (d,) = ecat.datagrams
    ok = d.wkc == nodes and d.data == rows.tobytes()
    print(f"  afterwards a configured LRD answers correctly: {ok}")


def live(nodes: int, size: int, frames: int, seed: int, timeout_ms: float, every: int) -> None:
    from emulator.live import netns_socket, veth_netns

    with veth_netns(prefix="skf-bench") as net:
        cmd = [
            *("ip", "netns", "exec", net.netns, sys.executable, "-m", "skinframes", "serve"),
            *("ecat", "--iface", net.slave, "--nodes", str(nodes), "--bytes", str(size)),
            *("--seed", str(SEED), "--samples", str(SAMPLES), "--json"),
        ]
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        proc = subprocess.Popen(
            cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        try:
            assert proc.stderr is not None
            proc.stderr.readline()  # "serving ..."
            answered = lost = 0
            t0 = time.monotonic()
            with netns_socket(net.master, net.netns) as sock:

                def exchange(frame: bytes, wait_ms: float = timeout_ms) -> bytes | None:
                    sock.send(frame)
                    deadline = time.monotonic() + wait_ms / 1000
                    while (left := deadline - time.monotonic()) > 0:
                        if select.select([sock.fileno()], [], [], left)[0]:
                            back = sock.recv()
                            if back is not None and len(back) == len(frame):
                                return back
                    return None

                for i, frame in enumerate(with_resets(frames, nodes, size, seed, every)):
                    if exchange(frame) is None:
                        lost += 1
                    else:
                        answered += 1
                    if i % 10_000 == 9_999:
                        print(f"  {i + 1} frames, {time.monotonic() - t0:.0f} s", file=sys.stderr)
                while select.select([sock.fileno()], [], [], 2.0)[0]:  # late answers
                    while sock.recv() is not None:
                        pass
                info = SlaveInfo.skin_patch(size)
                for frame in master_reset_frames(nodes) + configure_frames(info, nodes):
                    exchange(frame, 2000)
                back = exchange(lrd_frame(nodes, size), 2000)
            assert proc.poll() is None, "serve ended"
            ok = False
            if back is None:
                print("  LRD: no answer")
            else:
                (d,) = ethercat.decode(back[14:])[0].datagrams
                payloads = taxel.sample_payloads(nodes, SAMPLES, size, seed=SEED)
                rows = np.frombuffer(d.data, np.uint8).reshape(nodes, size)
                common = one_sample(rows, payloads)
                ok = d.wkc == nodes and bool(common)
                if not ok:
                    print(f"  LRD: wkc {d.wkc}, no published sample common to all rows")
        finally:
            proc.send_signal(signal.SIGINT)
            out, err = proc.communicate(timeout=120)
    summary = json.loads(out) if proc.returncode == 0 else {"rc": proc.returncode, "stderr": err}
    print(f"live: {frames} hostile frames to serve ecat --nodes {nodes} over veth")
    print(f"  answered {answered}, not answered {lost}, {time.monotonic() - t0:.0f} s")
    print(f"  afterwards a configured LRD answers correctly: {ok}")
    keys = ("frames_in", "frames_out", "dropped", "errors", "cpu_us_max", "over_budget")
    print("  serve:", json.dumps({k: summary.get(k) for k in keys}))
    if summary.get("error_messages"):
        print("  not processed:", summary["error_messages"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, default=160)
    ap.add_argument(
        "--bytes",
        type=int,
        default=8,
        help="taxel bytes per patch (the LRD of the whole image must fit one frame)",
    )
    ap.add_argument("--frames", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--live", action="store_true", help="send them to serve over veth (root)")
    ap.add_argument("--timeout-ms", type=float, default=50.0)
    ap.add_argument(
        "--reset-every", type=int, default=500, help="hostile frames between master resets"
    )
    args = ap.parse_args()
    if args.live:
        with contextlib.suppress(KeyboardInterrupt):
            live(args.nodes, args.bytes, args.frames, args.seed, args.timeout_ms, args.reset_every)
    else:
        in_process(args.nodes, args.bytes, args.frames, args.seed, args.reset_every)


if __name__ == "__main__":
    main()
