"""The Wireshark Lua post-dissector that shows taxels: ``skin.lua`` from ``skin.lua.in``.

The template (``skin.lua.in`` beside this module) holds the Lua; every number in it comes from
here, from the skinframes constants that define it: the patch layout (:mod:`skinframes.taxel`,
paper eq. 1), the contact threshold, the EPL PRes layout (DS 301 4.6.1.1.4,
:mod:`skinframes.powerlink.schemas`) and the EtherCAT commands (ETG.1000.4 Table 14). Where the
taxels sit is the rule of :func:`skinframes.taxels_from_capture`, so both show the same taxels
(tests/skinframes/test_wireshark_lua.py runs the system tshark with the script).
"""

from __future__ import annotations

from pathlib import Path
from typing import Final

from skinframes import ethercat, ethernet, taxel
from skinframes.capture_taxels import ETHERTYPE_VLAN, LAYOUTS, TAXEL_COMMANDS
from skinframes.errors import FieldRangeError
from skinframes.powerlink.enums import MAX_CN_NODE_ID, MIN_CN_NODE_ID, MessageType
from skinframes.powerlink.schemas import PDO_HEADER_BYTES, PDO_SIZE_OFFSET, SRC_OFFSET

__all__ = ["FIELDS", "TEMPLATE", "lua_plugin"]

TEMPLATE: Final = Path(__file__).with_name("skin.lua.in")
FIELDS: Final = ("skin.patch", "skin.triangle", "skin.taxel", "skin.contact")
MAX_LOGICAL_ADDRESS: Final = 0xFFFFFFFF  # 32-bit logical address space (ETG.1000.4)


def lua_plugin(
    *,
    nodes: int | None = None,
    bytes_per_node: int = taxel.PATCH_BYTES,
    layout: str = "logical",
    base: int = 0,
) -> str:
    """The Lua text of the post-dissector.

    Args:
        nodes: patches to show (EPL CNs 1..nodes, EtherCAT slaves 0..nodes-1); None: any.
        bytes_per_node: taxel bytes per node (EPL: at most this many of a PRes payload; EtherCAT:
            the stride of the nodes in the logical image).
        layout: ``logical`` (any LRD/LRW overlapping the image) or ``per-slave`` (only
            datagrams that start at a node's address and hold at most one node).
        base: logical address of node 0.

    Raises:
        FieldRangeError: a value out of range.
    """
    if nodes is not None and nodes < 1:
        raise FieldRangeError(f"nodes {nodes}, need >= 1", field="nodes")
    if not 1 <= bytes_per_node <= ethercat.MAX_DATAGRAM_DATA_BYTES:
        raise FieldRangeError(
            f"bytes per node {bytes_per_node}, need 1..{ethercat.MAX_DATAGRAM_DATA_BYTES}",
            field="bytes",
        )
    if layout not in LAYOUTS:
        raise FieldRangeError(f"layout {layout!r}; choose from {list(LAYOUTS)}", field="layout")
    if not 0 <= base <= MAX_LOGICAL_ADDRESS:
        raise FieldRangeError(f"base address {base:#x} is not 32 bits", field="base")
    from skinframes import __version__

    config = f"{nodes or 'any'} nodes x {bytes_per_node} bytes, layout {layout}"
    values = {
        "VERSION": __version__,
        "CONFIG": config,
        "PATCH_BYTES": taxel.PATCH_BYTES,
        "TAXELS_PER_TRIANGLE": taxel.TAXELS_PER_TRIANGLE,
        "TRIANGLES_PER_PATCH": taxel.TRIANGLES_PER_PATCH,
        "CONTACT_THRESHOLD": taxel.CONTACT_THRESHOLD,
        "ETHERTYPE_EPL": f"0x{ethernet.ETHERTYPE_EPL:04X}",
        "ETHERTYPE_ECAT": f"0x{ethernet.ETHERTYPE_ECAT:04X}",
        "ETHERTYPE_VLAN": f"0x{ETHERTYPE_VLAN:04X}",
        "EPL_PRES": int(MessageType.PRES),
        "EPL_PDO_HEADER_BYTES": PDO_HEADER_BYTES,
        "EPL_SIZE_OFFSET": PDO_SIZE_OFFSET,
        "EPL_SRC_OFFSET": SRC_OFFSET,
        "EPL_MIN_CN": MIN_CN_NODE_ID,
        "EPL_MAX_CN": MAX_CN_NODE_ID,
        "ECAT_TYPE_COMMANDS": int(ethercat.FrameType.ECAT),
        "ECAT_TAXEL_COMMANDS": ", ".join(
            f'[{c}] = "{ethercat.Command(c).name}"' for c in TAXEL_COMMANDS
        ),
        "NODES": nodes or 0,
        "BYTES": bytes_per_node,
        "BASE": base,
        "PER_SLAVE": "true" if layout == "per-slave" else "false",
    }
    text = TEMPLATE.read_text(encoding="utf-8")
    for key, value in values.items():
        text = text.replace(f"@{key}@", str(value))
    if "@" in text.replace("@VERSION@", ""):
        missing = sorted({part.split("@")[0] for part in text.split("@")[1::2]})
        raise AssertionError(f"skin.lua.in: placeholders left: {missing}")
    return text
