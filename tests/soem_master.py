"""Drive an emulated chain with pysoem (SOEM 1.4): scan, map, OP, cycles; one JSON on stdout.

Run inside the network namespace (``ip netns exec NS python tests/soem_master.py ...``). Every
cycle's input image (all slaves' ``input`` bytes in order) is appended to ``--inputs-out``.
Timeouts are generous: the machine is shared, and a lost frame costs SOEM a few kernel ticks.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import pysoem


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("iface")
    p.add_argument("--cycles", type=int, default=1000)
    p.add_argument("--inputs-out", required=True)
    p.add_argument("--timeout-us", type=int, default=100_000)
    p.add_argument("--dc", action="store_true", help="config_dc, SYNC0 every 1 ms on each slave")
    args = p.parse_args()
    t = pysoem.settings.timeouts
    t.ret, t.safe, t.eeprom, t.state = 50_000, 500_000, 500_000, 20_000_000
    master = pysoem.Master()
    master.open(args.iface)
    out: dict[str, object] = {}
    try:
        t0 = time.perf_counter()
        out["config_init"] = master.config_init()
        out["config_init_s"] = round(time.perf_counter() - t0, 3)
        slaves = master.slaves
        out["slaves"] = [{"man": s.man, "id": s.id, "rev": s.rev, "name": s.name} for s in slaves]
        # uncached SII reads and a write/read-back through SOEM's EEPROM functions
        out["serials"] = [int.from_bytes(s.eeprom_read(0x0E), "little") for s in slaves]
        slaves[0].eeprom_write(0x20, b"\xef\xbe")
        out["eeprom_word_0x20"] = slaves[0].eeprom_read(0x20)[:2].hex()
        t1 = time.perf_counter()
        out["iomap_bytes"] = master.config_map()
        out["config_map_s"] = round(time.perf_counter() - t1, 3)
        out["expected_wkc"] = master.expected_wkc
        if args.dc:
            out["config_dc"] = master.config_dc()
            for s in slaves:
                s.dc_sync(True, 1_000_000)
            out["dc_delays"] = [int.from_bytes(s._fprd(0x0928, 4), "little") for s in slaves]
            out["dc_activation"] = [s._fprd(0x0981, 1)[0] for s in slaves]
        out["safeop"] = master.state_check(pysoem.SAFEOP_STATE, 10_000_000)
        master.state = pysoem.OP_STATE
        master.write_state()
        for _ in range(200):
            master.send_processdata()
            master.receive_processdata(args.timeout_us)
            if master.state_check(pysoem.OP_STATE, 5_000) == pysoem.OP_STATE:
                break
        out["op"] = master.state_check(pysoem.OP_STATE, 10_000_000)
        master.read_state()
        out["states"] = sorted({s.state for s in slaves})
        out["al_status_codes"] = sorted({s.al_status for s in slaves})
        wkcs, cycle_us = [], []
        with open(args.inputs_out, "wb") as f:
            for _ in range(args.cycles):
                c0 = time.perf_counter()
                master.send_processdata()
                wkcs.append(master.receive_processdata(args.timeout_us))
                cycle_us.append((time.perf_counter() - c0) * 1e6)
                f.write(b"".join(bytes(s.input) for s in slaves))
        out["wkc"] = wkcs
        if args.dc:  # system time difference 0x092C: bit 31 sign (1: local smaller), 0-30 ns
            raw = [int.from_bytes(s._fprd(0x092C, 4), "little") for s in slaves]
            out["dc_diff_ns"] = [-(v & 0x7FFFFFFF) if v & 0x80000000 else v for v in raw]
            out["dc_sync0_status"] = [s._fprd(0x098E, 1)[0] for s in slaves]
            out["dc_time"] = master.dc_time
        out["cycle_us"] = {
            "median": round(statistics.median(cycle_us), 1),
            "p99": round(sorted(cycle_us)[int(0.99 * len(cycle_us))], 1),
            "max": round(max(cycle_us), 1),
        }
        master.state = pysoem.INIT_STATE
        master.write_state()
        out["init"] = master.state_check(pysoem.INIT_STATE, 10_000_000)
    finally:
        master.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
