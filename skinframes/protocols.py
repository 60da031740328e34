"""The protocols' names as the command line and JSON spell them, and the aliases accepted for them.

``ecat`` is EtherCAT's name in every command, JSON key and file name; ``ethercat`` (as Wireshark
and most users write it) is accepted wherever a protocol is named and means the same.
"""

from __future__ import annotations

from typing import Final

__all__ = ["PROTOCOLS", "PROTOCOL_ALIASES", "protocol_name"]

PROTOCOLS: Final = ("epl", "ecat")  # Ethernet POWERLINK, EtherCAT
PROTOCOL_ALIASES: Final = {"ethercat": "ecat"}  # alias -> name


def protocol_name(text: str) -> str:
    """The protocol's name for ``text``: an alias becomes its name, anything else is unchanged
    (``protocol_name("ethercat") == "ecat"``); case is kept, so ``ECAT`` stays unknown."""
    return PROTOCOL_ALIASES.get(text, text)
