"""Drive an emulated chain with pysoem (SOEM 1.4): scan, map, OP, cycles; one JSON on stdout.

Run inside the network namespace (``ip netns exec NS python tests/soem_master.py ...``). Every
cycle's input image (all slaves' ``input`` bytes in order) is appended to ``--inputs-out``.
Timeouts are generous: the machine is shared, and a lost frame costs SOEM a few kernel ticks.

``--coe``: in PRE-OP, SDO reads and writes on the first slave (identity, PDO assignment and
mapping, abort codes, the SDO information dictionary) and its SII's TXPDO category read through
SOEM's EEPROM functions, for the test to compare. ``--assign-triangles K``: before mapping, every
slave's TxPDO assignment 0x1C13 is rewritten to its first K PDOs (slave 0 entry by entry, the
others by complete access), so that SOEM's ``config_map`` computes a smaller IO map.
"""

from __future__ import annotations

import argparse
import json
import statistics
import struct
import time
from typing import Any

import pysoem

TXPDO_CATEGORY, END_CATEGORY, FIRST_CATEGORY_WORD = 50, 0xFFFF, 0x40  # ETG.2010 Tables 2, 3


def sii_words(slave: Any, word: int, count: int) -> bytes:
    """``count`` SII words from ``word`` on, through SOEM's EEPROM read (4 bytes a call)."""
    out = b"".join(slave.eeprom_read(w) for w in range(word, word + count, 2))
    return out[: 2 * count]


def sii_txpdos(slave: Any) -> dict[str, list[Any]]:
    """The TXPDO category of the slave's SII: {pdo index: [sm, [entry words]]} (ETG.2010 T11/12),
    the entry words written as 0x1A00:n values are (index << 16 | subindex << 8 | bit length)."""
    word = FIRST_CATEGORY_WORD
    while True:
        kind, size = struct.unpack("<HH", sii_words(slave, word, 2))
        if kind == END_CATEGORY:
            return {}
        if kind == TXPDO_CATEGORY:
            data = sii_words(slave, word + 2, size)
            break
        word += 2 + size
    pdos: dict[str, list[Any]] = {}
    pos = 0
    while pos + 8 <= len(data):
        index, n, sm = struct.unpack_from("<HBB", data, pos)
        pos += 8
        entries = []
        for _ in range(n):
            e_index, e_sub, _name, _dtype, bits = struct.unpack_from("<HBBBB", data, pos)
            entries.append(e_index << 16 | e_sub << 8 | bits)
            pos += 8
        pdos[str(index)] = [sm, entries]
    return pdos


def abort_code(call: Any) -> int | None:
    """The SDO abort code the call ends with (None if it succeeds)."""
    try:
        call()
    except pysoem.SdoError as exc:
        return int(exc.abort_code)
    return None


def coe_checks(slave: Any) -> dict[str, Any]:
    """SDO traffic with one slave in PRE-OP: what the test compares with the SII and the spec."""
    u = int.from_bytes
    out: dict[str, Any] = {"vendor_id": u(slave.sdo_read(0x1018, 1), "little")}
    out["identity"] = [u(slave.sdo_read(0x1018, k), "little") for k in range(1, 5)]
    out["device_name"] = slave.sdo_read(0x1008, 0).decode("ascii")
    n = slave.sdo_read(0x1C13, 0)[0]
    out["assign"] = [u(slave.sdo_read(0x1C13, k), "little") for k in range(1, n + 1)]
    out["mappings"] = {}
    for pdo in out["assign"]:
        m = slave.sdo_read(pdo, 0)[0]
        out["mappings"][str(pdo)] = [u(slave.sdo_read(pdo, k), "little") for k in range(1, m + 1)]
    out["assign_ca"] = slave.sdo_read(0x1C13, 0, ca=True).hex()
    out["sm_types"] = list(slave.sdo_read(0x1C00, 0, ca=True)[2:])
    out["abort_unknown_object"] = abort_code(lambda: slave.sdo_read(0x2000, 0))
    out["abort_unknown_subindex"] = abort_code(lambda: slave.sdo_read(0x1018, 9))
    out["abort_read_only"] = abort_code(lambda: slave.sdo_write(0x1018, 1, bytes(4)))
    out["abort_length"] = abort_code(lambda: slave.sdo_write(0x8000, 2, bytes(2)))
    out["abort_range"] = abort_code(lambda: slave.sdo_write(0x8000, 1, struct.pack("<I", 1)))
    slave.sdo_write(0x8000, 1, struct.pack("<I", 2000))
    out["sampling_period_us"] = u(slave.sdo_read(0x8000, 1), "little")
    out["od"] = [
        [
            o.index,
            o.name.decode() if isinstance(o.name, bytes) else o.name,
            o.object_code,
            len(o.entries),
        ]
        for o in slave.od
    ]
    out["sii_txpdos"] = sii_txpdos(slave)
    return out


def reassign(slaves: Any, triangles: int) -> None:
    """Assign each slave's first ``triangles`` TxPDOs to SM3 (0x1C13) in PRE-OP."""
    pdos = [0x1A00 + t for t in range(triangles)]
    first = slaves[0]
    first.sdo_write(0x1C13, 0, bytes([0]))  # entries change only while subindex 0 is 0
    for k, pdo in enumerate(pdos, start=1):
        first.sdo_write(0x1C13, k, struct.pack("<H", pdo))
    first.sdo_write(0x1C13, 0, bytes([len(pdos)]))
    image = bytes([len(pdos), 0]) + b"".join(struct.pack("<H", p) for p in pdos)
    for s in slaves[1:]:
        s.sdo_write(0x1C13, 0, image, ca=True)


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("iface")
    p.add_argument("--cycles", type=int, default=1000)
    p.add_argument("--inputs-out", required=True)
    p.add_argument("--timeout-us", type=int, default=1_000_000)  # waits only when late
    p.add_argument("--coe", action="store_true")
    p.add_argument("--assign-triangles", type=int, default=0)
    p.add_argument("--dc", action="store_true", help="config_dc, SYNC0 every 1 ms on each slave")
    args = p.parse_args()
    t = pysoem.settings.timeouts
    t.ret, t.safe, t.eeprom, t.state = 50_000, 500_000, 500_000, 20_000_000
    # CdefSlave._fprd waits 2 ms unless told: its reads below get the same --timeout-us as the
    # process data, so a busy machine slows the test down but never fails it
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
        if args.coe:
            out["preop"] = master.state_check(pysoem.PREOP_STATE, 10_000_000)
            out["coe"] = coe_checks(slaves[0])
        if args.assign_triangles:
            reassign(slaves, args.assign_triangles)
        t1 = time.perf_counter()
        out["iomap_bytes"] = master.config_map()
        out["config_map_s"] = round(time.perf_counter() - t1, 3)
        out["expected_wkc"] = master.expected_wkc
        if args.dc:
            out["config_dc"] = master.config_dc()
            for s in slaves:
                s.dc_sync(True, 1_000_000)
            out["dc_delays"] = [
                int.from_bytes(s._fprd(0x0928, 4, args.timeout_us), "little") for s in slaves
            ]
            out["dc_activation"] = [s._fprd(0x0981, 1, args.timeout_us)[0] for s in slaves]
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
            raw = [int.from_bytes(s._fprd(0x092C, 4, args.timeout_us), "little") for s in slaves]
            out["dc_diff_ns"] = [-(v & 0x7FFFFFFF) if v & 0x80000000 else v for v in raw]
            out["dc_sync0_status"] = [s._fprd(0x098E, 1, args.timeout_us)[0] for s in slaves]
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
