"""``skinframes epl-config``: the CDC with which an openPOWERLINK MN runs a skin of N patches."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from skinframes.errors import SkinframesError
from skinframes.powerlink import MAX_CN_NODE_ID, MIN_CN_NODE_ID
from skinframes.powerlink.cdc import (
    MAX_TAXEL_BYTES,
    MN_PDO_CHANNELS,
    encode_cdc,
    skin_cdc,
    to_text,
)
from skinframes.text import escape
from skinframes_cli.options import bounded_int, int_list_in, int_up_to, out_path
from skinframes_cli.streams import output

MAX_TIME_US = 4_294_967  # 0x1F92 and 0x1F8A/2 hold ns in an UNSIGNED32
# below this much of the cycle free beyond the model's worst cycle, a note: openPOWERLINK's MN
# counted cycles exceeded after OPERATIONAL in 5 of 6 runs with 0.6 ms free, in 1-2 of 4 with
# 1.5-2.4 ms and 1 of 7 with 3.3 ms (benchmarks/README, the live epl-config test's table)
ROOM_US = 1_000


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "epl-config",
        help="write the CDC (mnobd.cdc) with which an openPOWERLINK MN runs a skin of N patches",
        description="Write the concise device configuration (CDC) for openPOWERLINK's MN: node "
        "assignment, cycle, PRes timeouts, payload limits, the MN's PDO channels and each CN's "
        "0x1F22 block (its taxels 0x6100/1 as one TPDO entry of 8*B bits, then 0x6000/1; "
        "0x6200/1 from the PReq), for `serve epl` or any CN with those objects. --cycle-us "
        "defaults to the model's cycle with every CN at its PRes timeout and a full "
        "asynchronous slot, rounded up to a whole millisecond.",
    )
    p.add_argument(
        "--nodes",
        type=int_up_to(MAX_CN_NODE_ID),
        required=True,
        help=f"CNs (patches), 1..{MN_PDO_CHANNELS} (the stock MN's PDO channels)",
    )
    p.add_argument(
        "--bytes",
        type=bounded_int(1, MAX_TAXEL_BYTES),
        required=True,
        help=f"taxel bytes per CN, 1..{MAX_TAXEL_BYTES}",
    )
    p.add_argument(
        "--node-ids",
        type=int_list_in(MIN_CN_NODE_ID, MAX_CN_NODE_ID),
        help="the CNs' node ids, a comma list or start:stop:step, one per node (default 1..N)",
    )
    p.add_argument(
        "--cycle-us",
        type=bounded_int(1, 2**32 - 1),
        help="cycle length 0x1006 in us (default: the model's worst cycle, rounded up to 1 ms)",
    )
    p.add_argument(
        "--pres-timeout-us",
        type=bounded_int(1, MAX_TIME_US),
        help="each CN's PRes timeout 0x1F92 and the asynchronous slot timeout 0x1F8A/2 in us "
        "(default 1000)",
    )
    p.add_argument("--out", type=out_path, required=True, help="the CDC file to write; - stdout")
    p.add_argument("--txt", type=out_path, help="also the openCONFIGURATOR text form (mnobd.txt)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Write the CDC (and its text)."""
    from emulator.epl.skin import node_ids
    from emulator.model.epl_config import (
        shortest_cycle_us,
        skin_config,
        worst_cycle_us,
    )

    if args.nodes > MN_PDO_CHANNELS:
        raise SkinframesError(
            f"--nodes {args.nodes}: the openPOWERLINK MN's object dictionary has "
            f"{MN_PDO_CHANNELS} RPDO and {MN_PDO_CHANNELS} TPDO channels, one of each per CN "
            f"(1..{MN_PDO_CHANNELS})"
        )
    if args.txt is not None and args.txt == args.out:
        raise SkinframesError("--txt: the same file as --out")
    ids = tuple(node_ids(args.nodes, args.node_ids))
    config = skin_config(ids, args.bytes, args.cycle_us, args.pres_timeout_us)
    timeout_us, cycle_us = config.pres_timeout_us, config.cycle_us
    payload = config.pres_payload_bytes
    entries = skin_cdc(config)
    shortest = shortest_cycle_us(len(ids), payload, 1.0)
    if cycle_us < shortest:
        raise SkinframesError(
            f"--cycle-us {cycle_us}: shorter than the model's cycle for {len(ids)} CNs of "
            f"{payload} PRes bytes even with 1 us CNs ({shortest:.1f} us)"
        )
    with output(args.out, "wb", what="--out") as f:
        f.write(encode_cdc(entries))
    if args.txt is not None:
        with output(args.txt, "w", what="--txt") as t:
            t.write(to_text(entries))
    worst = worst_cycle_us(len(ids), payload, timeout_us, timeout_us)
    free = cycle_us - worst
    source = "given" if args.cycle_us else "the model's worst cycle rounded up to 1 ms"
    print(
        f"wrote {escape(args.out)}: {len(ids)} CNs x {args.bytes} taxel bytes, cycle "
        f"{cycle_us} us ({source}), PRes timeout {timeout_us} us, PRes payload {payload} bytes, "
        f"worst cycle {worst:.1f} us" + (f", {free:.1f} us free" if free >= 0 else ""),
        file=sys.stderr,
    )
    if free < 0:
        print(
            f"cycle {cycle_us} us shorter than the worst cycle {worst:.1f} us: CNs that use "
            "their PRes timeout make the MN count cycles exceeded (0x1C02)",
            file=sys.stderr,
        )
    elif free < ROOM_US:
        print(
            f"note: {free:.0f} us free beyond the worst cycle; a real MN needs room for its "
            "own timing (openPOWERLINK's counted cycles exceeded, 0x1C02, in 5 of 6 runs with "
            "0.6 ms free): a longer --cycle-us or a shorter --pres-timeout-us gives it more",
            file=sys.stderr,
        )
    return 0
