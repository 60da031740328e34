"""Drive a line with KickCAT's master (its Python bindings, the ``kickcat`` wheel): scan, map,
SAFE-OP, OP, cycles.

Run inside the network namespace (``ip netns exec NS python tests/kickcat_master.py IFACE``);
prints one JSON document: each slave's station address, input and output bytes as KickCAT's
mapping gave them and state after OP; the SDO upload of 0x1018:1 (the vendor id) from the
slaves ``--sdo-slaves`` names (positions); and each cycle's input bytes per slave (hex), read
with ``Bus.process_data``, which raises on a datagram whose working counter is not the
expected one.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import kickcat
from kickcat import State

STATE_NAMES = {
    State.INIT: "init",
    State.PREOP: "preop",
    State.SAFE_OP: "safeop",
    State.OPERATIONAL: "operational",
}


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("iface")
    p.add_argument("--cycles", type=int, default=200)
    p.add_argument("--link-timeout-s", type=float, default=0.1)
    p.add_argument("--io-bytes", type=int, default=65536)
    p.add_argument("--sdo-slaves", type=int, nargs="*", default=[])
    args = p.parse_args()
    link = kickcat.create_link(args.iface, "")  # "": no redundancy interface
    # KickCAT's default frame timeout is 2 ms; a Python ESC answers a long line in about 130 us,
    # with outliers of several ms on a busy machine. Without a redundancy interface KickCAT
    # waits one whole timeout after each broadcast (Link::writeThenRead reads for the answer
    # on the missing second interface too): the start's SII reads cost one each.
    link.set_timeout(args.link_timeout_s)
    bus = kickcat.Bus(link)
    out: dict[str, Any] = {"phase_s": {}}
    t = time.monotonic()

    def phase(name: str) -> None:
        nonlocal t
        now = time.monotonic()
        out["phase_s"][name] = round(now - t, 3)
        t = now

    bus.init(0.1)  # the PDI watchdog; reset, scan, addresses, SII, mailboxes; ends in PRE-OP
    phase("init")
    slaves = bus.slaves()
    out["detected"] = len(slaves)
    out["vendor_ids"] = [
        int.from_bytes(bus.read_sdo(slaves[k], 0x1018, 1, kickcat.PARTIAL, 4, 1.0), "little")
        for k in args.sdo_slaves
    ]
    phase("sdo")
    bus.create_mapping(args.io_bytes)
    phase("mapping")
    bus.request_state(State.SAFE_OP)
    bus.wait_for_state(State.SAFE_OP, 10.0)
    for s in slaves:
        if s.output_size:
            s.set_output_bytes(bytes(s.output_size))
    phase("safeop")
    bus.process_data_no_check()  # valid outputs before OP (ETG.1000.6 SAFE-OP -> OP)
    bus.request_state(State.OPERATIONAL)
    bus.wait_for_state(State.OPERATIONAL, 10.0, bus.process_data_no_check)
    phase("op")
    out["slaves"] = [
        {
            "address": s.address,
            "state": STATE_NAMES[bus.get_state(s)],
            "input_bytes": s.input_size,
            "output_bytes": s.output_size,
        }
        for s in slaves
    ]
    inputs = []
    for _ in range(args.cycles):
        bus.process_data()
        inputs.append([s.input_data.hex() for s in slaves])
        time.sleep(0.001)
    out["inputs"] = inputs
    phase("cycles")
    bus.request_state(State.INIT)
    bus.wait_for_state(State.INIT, 10.0)
    out["init"] = True
    phase("back_to_init")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
