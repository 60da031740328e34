"""Ethernet II framing (IEEE 802.3-2018 clause 3): addresses, EtherType, padding, FCS, wire sizes.

pcap LINKTYPE_ETHERNET carries a frame without preamble and FCS, so ``to_bytes()`` returns exactly
that; the wire adds :data:`PREAMBLE_SFD_BYTES` before and :data:`FCS_BYTES` after, and an
inter-frame gap of :data:`IFG_BYTES` separates two frames (:func:`wire_bytes`).
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field
from typing import ClassVar, Final, Protocol

import construct as cs

from skinframes.errors import FieldRangeError, FrameTooLargeError, TruncatedError
from skinframes.findings import Finding

__all__ = [
    "DEFAULT_BIT_RATE_BPS",
    "ETHERTYPE_ECAT",
    "ETHERTYPE_EPL",
    "FCS_BYTES",
    "HEADER_BYTES",
    "IFG_BYTES",
    "MAX_PAYLOAD_BYTES",
    "MIN_FRAME_BYTES",
    "MIN_PAYLOAD_BYTES",
    "OVERHEAD_BYTES",
    "PREAMBLE_SFD_BYTES",
    "EthernetFrame",
    "Payload",
    "Tag",
    "fcs",
    "flip_bit",
    "format_mac",
    "mac",
    "padding_for",
    "wire_bytes",
]

# --- sizes (IEEE 802.3-2018 3.1.1, 3.2; paper Fig. 4 and eq. 4) -------------------------------
MAC_BYTES: Final = 6
ETHERTYPE_BYTES: Final = 2
HEADER_BYTES: Final = 2 * MAC_BYTES + ETHERTYPE_BYTES  # 14
FCS_BYTES: Final = 4  # CRC-32, 802.3 3.2.9
PREAMBLE_SFD_BYTES: Final = 8  # 7 preamble + 1 SFD, 802.3 3.2.1-3.2.2
IFG_BYTES: Final = 12  # 96 bit times, 802.3 4.4.2
MIN_PAYLOAD_BYTES: Final = 46  # minFrameSize 64 - header 14 - FCS 4
DEFAULT_BIT_RATE_BPS: Final = (
    100_000_000  # 100BASE-TX (802.3 clause 24/25): pcapng if_speed default
)
MAX_PAYLOAD_BYTES: Final = 1500
MIN_FRAME_BYTES: Final = HEADER_BYTES + MIN_PAYLOAD_BYTES  # 60, as captured (no FCS)
MAX_FRAME_BYTES: Final = HEADER_BYTES + MAX_PAYLOAD_BYTES  # 1514, as captured
OVERHEAD_BYTES: Final = PREAMBLE_SFD_BYTES + HEADER_BYTES + FCS_BYTES  # 26: the paper's E_ov

# --- EtherTypes (IEEE registry) -----------------------------------------------------------------
ETHERTYPE_EPL: Final = 0x88AB  # Ethernet POWERLINK, EPSG DS 301
ETHERTYPE_ECAT: Final = 0x88A4  # EtherCAT, ETG.1000.4

header_schema = cs.Struct(
    "dst" / cs.Bytes(MAC_BYTES),
    "src" / cs.Bytes(MAC_BYTES),
    "ethertype" / cs.Int16ub,  # the only big-endian field of EPL and EtherCAT frames
)

_HEADER = struct.Struct(">6s6sH")


def mac(text: str) -> bytes:
    """Parse ``"02:00:00:00:00:01"`` (``-`` also accepted) into 6 bytes."""
    parts = text.replace("-", ":").split(":")
    if len(parts) != MAC_BYTES:
        raise FieldRangeError(f"MAC address {text!r}: expected 6 octets, found {len(parts)}")
    try:
        return bytes(int(p, 16) for p in parts)
    except ValueError as exc:
        raise FieldRangeError(f"MAC address {text!r}: {exc}") from exc


def format_mac(addr: bytes) -> str:
    """Format 6 bytes as ``"02:00:00:00:00:01"``."""
    return addr.hex(":")


def is_group(addr: bytes) -> bool:
    """True when the I/G bit (first octet, bit 0) marks a group (multicast/broadcast) address."""
    return bool(addr[0] & 0x01)


def padding_for(frame_bytes: int) -> int:
    """Zero bytes needed to pad a frame of ``frame_bytes`` (no FCS) to the 60-byte minimum."""
    return max(0, MIN_FRAME_BYTES - frame_bytes)


def fcs(frame: bytes) -> bytes:
    """The 4-byte frame check sequence (CRC-32, 802.3 3.2.9) as it follows the frame on the wire."""
    return struct.pack("<I", zlib.crc32(frame) & 0xFFFFFFFF)


def flip_bit(frame: bytes, bit: int) -> bytes:
    """``frame`` with bit number ``bit`` inverted: a bit error on the link.

    Bit 0 is the least significant bit of byte 0, bit 8 that of byte 1, and so on; as octets go
    on the wire least significant bit first (IEEE 802.3-2018 3.3), bit ``n`` is also the n-th
    bit sent after the SFD. The FCS of the result no longer matches the frame's.

    Raises:
        FieldRangeError: ``bit`` outside 0 .. 8 * len(frame) - 1.
    """
    if not 0 <= bit < 8 * len(frame):
        raise FieldRangeError(
            f"bit {bit} is outside the frame's {8 * len(frame)} bits", field="bit", offset=bit // 8
        )
    out = bytearray(frame)
    out[bit >> 3] ^= 1 << (bit & 7)
    return bytes(out)


def wire_bytes(frame_bytes: int) -> int:
    """Bytes a frame occupies on the wire: preamble+SFD, padded frame, FCS (the IFG not included).

    Args:
        frame_bytes: length of the frame as captured (header + payload, no FCS).
    """
    return PREAMBLE_SFD_BYTES + max(frame_bytes, MIN_FRAME_BYTES) + FCS_BYTES


def unpack_header(data: bytes) -> tuple[bytes, bytes, int]:
    """(destination MAC, source MAC, EtherType) of a frame.

    Raises:
        TruncatedError: fewer than 14 bytes.
    """
    if len(data) < HEADER_BYTES:
        raise TruncatedError(
            f"Ethernet: {len(data)} bytes, the header needs {HEADER_BYTES}", offset=len(data)
        )
    dst, src, ethertype = _HEADER.unpack_from(data)
    return dst, src, ethertype


class Tag(Protocol):
    """What sits between source MAC and EtherType: a VLAN tag (:class:`skinframes.vlan.VlanTag`)."""

    def to_bytes(self) -> bytes:
        """The tag's 4 bytes."""
        ...


class Payload(Protocol):
    """What an Ethernet frame can carry besides raw bytes: an EPL or EtherCAT message."""

    ETHERTYPE: ClassVar[int]

    def to_bytes(self) -> bytes:
        """The payload's bytes, without Ethernet padding."""
        ...


@dataclass(frozen=True, slots=True)
class EthernetFrame:
    """An Ethernet II frame as captured: header, payload, padding (no preamble, no FCS).

    Attributes:
        dst: destination MAC, 6 bytes.
        src: source MAC, 6 bytes.
        payload: an EPL or EtherCAT message, or raw bytes for other EtherTypes.
        ethertype: derived from the payload when None.
        padding: bytes after the payload. None means "zeros up to the 60-byte minimum", which is
            what a decoder reports when the frame carries exactly that; any other trailing bytes
            are kept verbatim so that ``to_bytes()`` returns the captured frame.
        findings: what the decoder noticed; not part of equality.
        tags: VLAN tags between source MAC and EtherType, outermost first (IEEE 802.1Q-2018
            9.5; :mod:`skinframes.vlan`); ``ethertype`` is then the one after the tags. Padding
            to the 60-byte minimum counts the tags (IEEE 802.3-2018 3.5: a tagged frame may be
            as short as an untagged one).
    """

    dst: bytes
    src: bytes
    payload: Payload | bytes
    ethertype: int | None = None
    padding: bytes | None = None
    findings: tuple[Finding, ...] = field(default=(), compare=False, repr=False)
    tags: tuple[Tag, ...] = ()

    def __post_init__(self) -> None:
        if len(self.dst) != MAC_BYTES or len(self.src) != MAC_BYTES:
            raise FieldRangeError("Ethernet: MAC addresses must be 6 bytes", field="dst/src")
        if self.ethertype is None:
            if isinstance(self.payload, bytes | bytearray):
                raise FieldRangeError("Ethernet: raw payload needs an explicit ethertype")
            object.__setattr__(self, "ethertype", self.payload.ETHERTYPE)
        elif not 0 <= self.ethertype <= 0xFFFF:
            raise FieldRangeError(f"Ethernet: ethertype {self.ethertype:#x} does not fit 16 bits")

    @property
    def payload_bytes(self) -> bytes:
        """The payload's bytes without padding."""
        p = self.payload
        return bytes(p) if isinstance(p, bytes | bytearray) else p.to_bytes()

    def to_bytes(self) -> bytes:
        """The frame as a pcap record holds it: header + payload + padding, no FCS."""
        body = self.payload_bytes
        if len(body) > MAX_PAYLOAD_BYTES:
            raise FrameTooLargeError(
                f"Ethernet: payload of {len(body)} bytes exceeds {MAX_PAYLOAD_BYTES}",
                field="payload",
            )
        head = _HEADER.pack(self.dst, self.src, self.ethertype)
        if self.tags:
            head = head[:12] + b"".join(t.to_bytes() for t in self.tags) + head[12:]
        pad = self.padding
        if pad is None:
            pad = bytes(padding_for(len(head) + len(body)))
        return head + body + pad

    def wire_bytes(self) -> int:
        """Bytes on the wire for this frame (preamble, padded frame with its tags, FCS; no IFG)."""
        return wire_bytes(len(self.to_bytes()))

    @classmethod
    def from_bytes(cls, data: bytes) -> EthernetFrame:
        """Decode the header only; the payload stays raw bytes (see :func:`skinframes.decode_frame`).

        Bytes past the 1500-byte maximum payload (VLAN-tagged or jumbo frames) are kept as a
        trailer in ``padding``, so that ``to_bytes()`` returns ``data`` at any length.
        """
        dst, src, ethertype = unpack_header(data)
        body = bytes(data[HEADER_BYTES:])
        return cls(dst, src, body[:MAX_PAYLOAD_BYTES], ethertype, padding=body[MAX_PAYLOAD_BYTES:])
