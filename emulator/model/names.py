"""One name per network of the paper's Tables I-III, and the old names still accepted.

The closed ring (the paper's "redundant" configuration, Table III, Fig. 11) is
``ecat_closed_ring``; its former name is ``ecat_redundant``. Every entry point that takes a
table name accepts both (:func:`table_name`), and every JSON document keyed by table
carries the old key beside the new one with the same value (:func:`with_old_keys`), so scripts
written against the old key keep working (docs/interface.md, "Old names"). Values that cannot
carry two names (the CSV ``table`` column, the file names ``demo`` writes) keep the old one:
:func:`old_name`.

Imports nothing of the engine: :mod:`emulator.net` may use it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Final, TypeVar

from emulator.errors import PresetError, TopologyError

__all__ = [
    "ECAT",
    "ECAT_CLOSED_RING",
    "EPL",
    "JSON_KEYS_HELP",
    "OLD_TABLE_NAMES",
    "TABLES",
    "closed_ring_flag",
    "is_closed_ring",
    "old_name",
    "table_name",
    "with_old_keys",
]

EPL: Final = "epl"  # Table I: Ethernet POWERLINK, MN and CNs behind hubs
ECAT: Final = "ecat"  # Table II: EtherCAT, open ring (the paper's "non-redundant")
ECAT_CLOSED_RING: Final = "ecat_closed_ring"  # Table III: EtherCAT, closed ring ("redundant")
TABLES: Final = (EPL, ECAT, ECAT_CLOSED_RING)
# Old name -> name. Accepted wherever a table is named; written beside the name in JSON.
OLD_TABLE_NAMES: Final[dict[str, str]] = {"ecat_redundant": ECAT_CLOSED_RING}
_OLD_NAME_OF: Final = {new: old for old, new in OLD_TABLE_NAMES.items()}
# For --help of the commands whose JSON is keyed by table.
JSON_KEYS_HELP: Final = f"keys {', '.join(TABLES)}, and " + ", ".join(
    f"{old}: the old name of {new}, same value" for old, new in OLD_TABLE_NAMES.items()
)

V = TypeVar("V")


def table_name(name: str) -> str:
    """The table's one name: ``name`` itself, or the name an old name stands for.

    Raises:
        PresetError: no table has this name.
    """
    if name in TABLES:
        return name
    if name in OLD_TABLE_NAMES:
        return OLD_TABLE_NAMES[name]
    raise PresetError(
        f"unknown table {name!r}; choose from {list(TABLES)} (old name: "
        + ", ".join(f"{old} = {new}" for old, new in OLD_TABLE_NAMES.items())
        + ")"
    )


def is_closed_ring(table: str) -> bool:
    """Whether ``table`` (either name) is the EtherCAT closed ring."""
    return table_name(table) == ECAT_CLOSED_RING


def old_name(table: str) -> str:
    """The name written where one value must serve old scripts (CSV rows, demo file names)."""
    name = table_name(table)
    return _OLD_NAME_OF.get(name, name)


def with_old_keys(doc: Mapping[str, V]) -> dict[str, V]:
    """``doc`` with each table key's old name right after it, holding the same value."""
    out: dict[str, V] = {}
    for key, value in doc.items():
        out[key] = value
        if key in _OLD_NAME_OF:
            out[_OLD_NAME_OF[key]] = value
    return out


def closed_ring_flag(closed_ring: bool | None, redundant: bool | None) -> bool:
    """The closed-ring flag of a Python call that takes ``closed_ring=`` and its old name
    ``redundant=`` (either, or both when they agree; neither: the open ring).

    Raises:
        TopologyError: both given and they disagree.
    """
    if closed_ring is not None and redundant is not None and bool(closed_ring) != bool(redundant):
        raise TopologyError("closed_ring and its old name redundant disagree")
    return bool(closed_ring if closed_ring is not None else redundant)
