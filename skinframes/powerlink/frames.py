"""EPL in Ethernet frames: the MAC addresses of each message, and decoding by MessageType.

:func:`decode` reads the common header and hands the bytes to the message class that owns them
(:mod:`.messages`); deviations become findings in capture mode (``strict=False``) and
:class:`~skinframes.errors.DecodeError` in strict mode.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Final

from skinframes import ethernet
from skinframes.errors import TruncatedError, decoding
from skinframes.findings import Finding
from skinframes.powerlink.enums import MessageType
from skinframes.powerlink.messages import (
    ASnd,
    EplMessage,
    PReq,
    PRes,
    RawMessage,
    SoA,
    SoC,
    check_node,
)
from skinframes.powerlink.schemas import HEADER_BYTES

# --- MAC addresses (DS 301 4.2.5.1.1; openPOWERLINK oplkdefs.h) ----------------------------------
MAC_SOC: Final = bytes.fromhex("01111e000001")  # C_DLL_MULTICAST_SOC
MAC_PRES: Final = bytes.fromhex("01111e000002")  # C_DLL_MULTICAST_PRES
MAC_SOA: Final = bytes.fromhex("01111e000003")  # C_DLL_MULTICAST_SOA
MAC_ASND: Final = bytes.fromhex("01111e000004")  # C_DLL_MULTICAST_ASND
MAC_AMNI: Final = bytes.fromhex("01111e000005")  # C_DLL_MULTICAST_AMNI


def node_mac(node_id: int) -> bytes:
    """The locally administered unicast MAC skinframes gives node ``node_id``: 02:00:00:00:0a:NN."""
    check_node("node_id", node_id)
    return bytes((0x02, 0, 0, 0, 0x0A, node_id))


def destination_mac(message: EplMessage) -> bytes:
    """The destination MAC openPOWERLINK uses for a message (multicast, or the CN's for PReq)."""
    if isinstance(message, SoC):
        return MAC_SOC
    if isinstance(message, PReq):
        return node_mac(message.dest)
    if isinstance(message, PRes):
        return MAC_PRES
    if isinstance(message, SoA):
        return MAC_SOA
    if isinstance(message, RawMessage) and message.message_type == MessageType.AMNI:
        return MAC_AMNI
    if isinstance(message, RawMessage) and message.message_type == MessageType.AINV:
        return MAC_SOA
    return MAC_ASND


def frame(message: EplMessage) -> ethernet.EthernetFrame:
    """Wrap a message in an Ethernet frame from its source node's MAC to its destination MAC."""
    return ethernet.EthernetFrame(destination_mac(message), node_mac(message.src), message)


# --- decoding ------------------------------------------------------------------------------------
Decoder = Callable[[bytes, bool, list[Finding]], tuple[EplMessage, int]]

# byte 0 -> the class that reads the message; any other value (AInv, AMNI, unknown types, bit 7
# set) is a RawMessage
DECODERS: Final[dict[int, Decoder]] = {
    MessageType.SOC: SoC._decode,
    MessageType.PREQ: PReq._decode,
    MessageType.PRES: PRes._decode,
    MessageType.SOA: SoA._decode,
    MessageType.ASND: ASnd._decode,
}

# decoders that check every length before one struct call and raise only DecodeErrors: they need
# no ``decoding`` context (a contextmanager costs about as much as one of them)
STRUCT_DECODERS: Final[frozenset[Decoder]] = frozenset(
    {SoC._decode, PReq._decode, PRes._decode, SoA._decode}
)


def decode(payload: bytes, *, strict: bool = True) -> tuple[EplMessage, int, list[Finding]]:
    """Decode the EPL part of a frame (the bytes after the EtherType).

    Args:
        payload: EPL message plus any Ethernet padding.
        strict: raise on reserved fields, unknown types and services, instead of reporting them
            as findings (capture mode keeps every byte).

    Returns:
        The message, how many bytes it occupies (the rest is padding), and findings.

    Raises:
        DecodeError: the message is truncated or (strict) deviates from the spec.
    """
    findings: list[Finding] = []
    buf = bytes(payload)
    if len(buf) < HEADER_BYTES:
        raise TruncatedError(f"EPL: {len(buf)} bytes, the common header needs {HEADER_BYTES}")
    decoder = DECODERS.get(buf[0], RawMessage._decode)
    if decoder in STRUCT_DECODERS:  # checked lengths, one struct call: nothing to translate
        message, used = decoder(buf, strict, findings)
    else:
        with decoding("EPL"):
            message, used = decoder(buf, strict, findings)
    return message, used, findings
