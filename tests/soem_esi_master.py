"""Drive a line of ESI-described slaves with pysoem (SOEM): scan, SII, CoE, map, OP, cycles.

Run inside the network namespace (``ip netns exec NS python tests/soem_esi_master.py IFACE``);
prints one JSON document: what SOEM found per slave (identity and name from the SII, the whole
SII image through SOEM's EEPROM reads, ``slave.od``, ``sdo_read(0x1018, 1)``, the input and
output bytes ``config_map`` gave it), the states reached and each cycle's working counter and
input bytes. The ESI slaves are the last of the line, one ``--image-bytes N`` each (the SII
bytes to read from it); ``--sdo INDEX:SUB`` (repeatable) reads that entry of each after
``config_map`` (which reads them itself first), one subindex at a time as SOEM's PDO-map
reader does.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import pysoem


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("iface")
    p.add_argument("--cycles", type=int, default=200)
    p.add_argument("--image-bytes", type=int, nargs="*", default=[])
    p.add_argument("--timeout-us", type=int, default=1_000_000)
    p.add_argument("--sdo", action="append", default=[], metavar="INDEX:SUB")
    args = p.parse_args()
    t = pysoem.settings.timeouts
    t.ret, t.safe, t.eeprom, t.state = 50_000, 500_000, 500_000, 20_000_000
    master = pysoem.Master()
    master.open(args.iface)
    out: dict[str, Any] = {}
    try:
        out["config_init"] = master.config_init()
        slaves = master.slaves
        out["slaves"] = [{"man": s.man, "id": s.id, "rev": s.rev, "name": s.name} for s in slaves]
        esi = slaves[len(slaves) - len(args.image_bytes) :]
        images = []
        for s, size in zip(esi, args.image_bytes, strict=True):
            images.append(b"".join(s.eeprom_read(w) for w in range(0, size // 2, 2)).hex())
        out["images"] = images
        out["preop"] = master.state_check(pysoem.PREOP_STATE, 10_000_000)
        coe: list[dict[str, Any]] = []
        for s in esi:
            entry: dict[str, Any] = {
                "vendor_id": int.from_bytes(s.sdo_read(0x1018, 1), "little"),
                "od": [[o.index, o.object_code, len(o.entries)] for o in s.od],
            }
            coe.append(entry)
        out["coe"] = coe
        out["iomap_bytes"] = master.config_map()
        for s, entry in zip(esi, coe, strict=True):
            for spec in args.sdo:
                index, sub = (int(x, 0) for x in spec.split(":"))
                entry.setdefault("sdo", {})[spec] = s.sdo_read(index, sub).hex()
        out["expected_wkc"] = master.expected_wkc
        out["io_bytes"] = [[len(bytes(s.output)), len(bytes(s.input))] for s in slaves]
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
        out["states"] = [s.state for s in slaves]
        out["al_status_codes"] = [s.al_status for s in slaves]
        wkcs, inputs = [], []
        for _ in range(args.cycles):
            master.send_processdata()
            wkcs.append(master.receive_processdata(args.timeout_us))
            inputs.append([bytes(s.input).hex() for s in esi])
            time.sleep(0.001)
        out["wkc"] = wkcs
        out["inputs"] = inputs
        master.state = pysoem.INIT_STATE
        master.write_state()
        out["init"] = master.state_check(pysoem.INIT_STATE, 10_000_000)
    finally:
        master.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
