"""``skinframes wireshark-plugin --out skin.lua``: the Lua post-dissector that shows taxels."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from skinframes.text import escape
from skinframes.wireshark_lua import lua_plugin
from skinframes_cli.options import add_skin_layout
from skinframes_cli.streams import STDIO, output


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "wireshark-plugin",
        help="write a Wireshark Lua plugin that shows the skin's taxels",
        description="Write a Lua post-dissector for Wireshark/tshark that shows, under each EPL "
        "PRes and each returned EtherCAT LRD/LRW datagram, the patch, its triangles, their "
        "12 taxels and whether each is in contact (fields skin.patch, skin.triangle, "
        "skin.taxel, skin.contact). Load it with tshark -X lua_script:FILE or copy it into "
        "Wireshark's personal Lua plugins folder.",
    )
    p.add_argument("--out", required=True, help="the .lua file to write; - for stdout")
    add_skin_layout(p, "in the capture")
    p.add_argument(
        "--base", type=int, default=0, help="EtherCAT logical address of node 0 (default 0)"
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Write the plugin."""
    text = lua_plugin(
        nodes=args.nodes,
        bytes_per_node=192 if args.bytes is None else args.bytes,
        layout=args.layout or "logical",
        base=args.base,
    )
    with output(args.out, "w", what="--out") as f:
        f.write(text)
    if args.out != STDIO:
        print(f"wrote {escape(args.out)}", file=sys.stderr)
    return 0
