"""A concise device configuration (CDC) for openPOWERLINK's MN, written as the kit's README says.

Format (tools/openpowerlink/README.md, "CDC (mnobd.cdc) format"): little-endian u32 entry count;
per entry u16 index, u8 sub-index, u32 size, then the data; a 0x1F22/<node> entry's data is a
nested block of the same format (what the MN writes to that node by SDO). The objects and their
order follow the kit's shipped ``mnobd.txt`` (openCONFIGURATOR's Demo_3CN); only the timing and
the CN's TPDO differ: here each CN sends its B taxel bytes (0x6100/1, 8*B bits at offset 0) and
its digital inputs (0x6000/1, the sample number) behind them.
"""

from __future__ import annotations

import struct
from pathlib import Path

CONF_DATE, CONF_TIME = 0x3124, 0x03735955  # as the shipped CDC (0x1F26/0x1F27)


def _entry(index: int, sub: int, data: bytes) -> bytes:
    return struct.pack("<HBI", index, sub, len(data)) + data


def _block(entries: list[bytes]) -> bytes:
    return struct.pack("<I", len(entries)) + b"".join(entries)


def u(value: int, size: int) -> bytes:
    return value.to_bytes(size, "little")


def mapping(index: int, sub: int, offset_bits: int, length_bits: int) -> int:
    """A PDO mapping entry (DS 301 6.4.9.2): length 16 | offset 16 | reserved 8 | sub 8 | index."""
    return length_bits << 48 | offset_bits << 32 | sub << 16 | index


def skin_cdc(
    node_ids: list[int],
    taxel_bytes: int,
    *,
    cycle_us: int = 10_000,
    pres_timeout_ns: int = 2_000_000,
    async_slot_ns: int = 2_000_000,
) -> bytes:
    """The MN's CDC for skin CNs ``node_ids`` with ``taxel_bytes`` each."""
    pres_bytes = max(36, taxel_bytes + 1)  # taxels, then 0x6000/1; 36 the lowest limit
    mn: list[bytes] = [_entry(0x1F81, n, u(0x00000007, 4)) for n in node_ids]
    for k in range(len(node_ids)):
        mn += [_entry(0x1600 + k, 0, u(0, 1)), _entry(0x1A00 + k, 0, u(0, 1))]
    mn += [
        _entry(0x1006, 0, u(cycle_us, 4)),
        _entry(0x1C02, 3, u(40, 4)),
        *(_entry(0x1C09, n, u(40, 4)) for n in node_ids),
        _entry(0x1C14, 0, u(50_000_000, 4)),
        *(_entry(0x1F26, n, u(CONF_DATE, 4)) for n in node_ids),
        *(_entry(0x1F27, n, u(CONF_TIME, 4)) for n in node_ids),
        _entry(0x1F8A, 2, u(async_slot_ns, 4)),
        *(_entry(0x1F8D, n, u(pres_bytes, 2)) for n in node_ids),
        *(_entry(0x1F92, n, u(pres_timeout_ns, 4)) for n in node_ids),
    ]
    for k, n in enumerate(node_ids):  # the MN reads each CN's first taxel, sends it one byte
        mn += [
            _entry(0x1400 + k, 1, u(n, 1)),
            _entry(0x1600 + k, 1, u(mapping(0xA4C0, k + 1, 0, 8), 8)),
            _entry(0x1800 + k, 1, u(n, 1)),
            _entry(0x1A00 + k, 1, u(mapping(0xA040, k + 1, 0, 8), 8)),
        ]
    for k in range(len(node_ids)):
        mn += [_entry(0x1600 + k, 0, u(1, 1)), _entry(0x1A00 + k, 0, u(1, 1))]
    for n in node_ids:
        cn = [
            _entry(0x1600, 0, u(0, 1)),
            _entry(0x1A00, 0, u(0, 1)),
            _entry(0x1006, 0, u(cycle_us, 4)),
            _entry(0x1020, 1, u(CONF_DATE, 4)),
            _entry(0x1020, 2, u(CONF_TIME, 4)),
            _entry(0x1C0B, 3, u(80, 4)),
            _entry(0x1C0D, 3, u(80, 4)),
            _entry(0x1C14, 0, u(50_000_000, 4)),
            _entry(0x1F98, 4, u(36, 2)),
            _entry(0x1F98, 5, u(pres_bytes, 2)),
            _entry(0x1600, 1, u(mapping(0x6200, 1, 0, 8), 8)),
            _entry(0x1A00, 1, u(mapping(0x6100, 1, 0, 8 * taxel_bytes), 8)),
            _entry(0x1A00, 2, u(mapping(0x6000, 1, 8 * taxel_bytes, 8), 8)),
            _entry(0x1600, 0, u(1, 1)),
            _entry(0x1A00, 0, u(2, 1)),
        ]
        mn.append(_entry(0x1F22, n, _block(cn)))
    mn += [_entry(0x1F81, n, u(0x80000007, 4)) for n in node_ids]
    return _block(mn)


def write_cdc(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path
