"""EtherType -> payload decoder: the one place that knows which protocols skinframes decodes."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Final, Generic, Literal, TypeVar

from skinframes import encap, ethercat, ethernet, powerlink
from skinframes.errors import (
    DecodeError,
    InvalidFieldError,
    LengthMismatchError,
    TruncatedError,
    UnknownProtocolError,
)
from skinframes.findings import Finding, error, info, warning

__all__ = ["DECODERS", "RepeatMemo", "decode_frame", "protocol_of"]

Decoder = Callable[..., tuple[ethernet.Payload, int, list[Finding]]]

DECODERS: Final[dict[int, Decoder]] = {
    ethernet.ETHERTYPE_EPL: powerlink.decode,
    ethernet.ETHERTYPE_ECAT: ethercat.decode,
}

PROTOCOL_NAMES: Final = {ethernet.ETHERTYPE_EPL: "epl", ethernet.ETHERTYPE_ECAT: "ecat"}


def protocol_of(frame: ethernet.EthernetFrame) -> Literal["epl", "ecat", "other"]:
    """``"epl"`` or ``"ecat"`` when the payload was decoded as such (also inside VLAN tags or
    UDP/IPv4), else ``"other"``."""
    message = encap.message_of(frame)
    if isinstance(message, ethercat.EcatFrame):
        return "ecat"
    if isinstance(message, bytes | bytearray):
        return "other"
    return "epl"


def decode_frame(data: bytes, *, strict: bool = False) -> ethernet.EthernetFrame:
    """Decode one Ethernet frame (as a pcap record holds it) down to EPL or EtherCAT.

    Args:
        data: the frame without FCS.
        strict: raise on any deviation from the specs (short or non-zero padding, leftover bytes,
            reserved fields, unknown EtherTypes). The default, capture mode, never loses a byte:
            what cannot be decoded stays raw bytes, and every deviation becomes a finding.

    Returns:
        An :class:`~skinframes.ethernet.EthernetFrame` whose ``to_bytes()`` equals ``data``.

    Raises:
        DecodeError: fewer than 14 bytes, or (strict) any deviation.
    """
    data = bytes(data)
    dst, src, ethertype = ethernet.unpack_header(data)
    tags, ethertype, head = encap.split(data)  # VLAN tags before the EtherType
    payload = data[head:]
    findings: list[Finding] = []
    if len(data) < ethernet.MIN_FRAME_BYTES:
        msg = f"Ethernet: {len(data)}-byte frame is shorter than the 60-byte minimum (unpadded)"
        if strict:
            raise TruncatedError(msg, offset=len(data))
        findings.append(info("eth.unpadded", msg + "; typical of a capture on the sending host"))
    if ethernet.is_group(src):
        msg = f"Ethernet: source MAC {ethernet.format_mac(src)} is a group address"
        if strict:  # IEEE 802.3 3.2.3: the source address is an individual address
            raise InvalidFieldError(msg, field="src", offset=6)
        findings.append(warning("eth.src.group", msg + " (Wireshark warns)"))
    decoder = DECODERS.get(ethertype)
    name = PROTOCOL_NAMES.get(ethertype, "other")
    if decoder is None and (inner := encap.decoder_for(ethertype, payload)) is not None:
        decoder, name = inner  # EPL or EtherCAT over UDP/IPv4
    if decoder is None:
        if strict:
            raise UnknownProtocolError(
                f"Ethernet: EtherType {ethertype:#06x} is not EPL or EtherCAT"
            )
        body, trailer = _raw(data, head)
        return ethernet.EthernetFrame(dst, src, body, ethertype, trailer, tuple(findings), tags)
    try:
        message, used, more = decoder(payload, strict=strict)
        if used > ethernet.MAX_PAYLOAD_BYTES:
            raise LengthMismatchError(
                f"Ethernet: the {used}-byte {name} message exceeds the "
                f"{ethernet.MAX_PAYLOAD_BYTES}-byte maximum payload",
                field="payload",
                offset=head,
            )
    except DecodeError as exc:
        if strict:
            raise
        findings.append(error(f"{name}.undecodable", f"{exc}; kept as raw bytes"))
        body, trailer = _raw(data, head)
        return ethernet.EthernetFrame(dst, src, body, ethertype, trailer, tuple(findings), tags)
    findings += more
    padding = payload[used:]
    auto = ethernet.padding_for(head + used)
    pad: bytes | None = padding
    fill = padding
    if len(padding) >= ethernet.FCS_BYTES and data[-4:] == ethernet.fcs(data[:-4]):
        fill = padding[: -ethernet.FCS_BYTES]  # a capture that kept the FCS (checked: correct)
        findings.append(info("eth.fcs", "Ethernet: the frame ends with its 4-byte FCS (correct)"))
    if len(padding) == auto and not any(padding):
        pad = None
    else:
        if any(fill):
            msg = (
                f"Ethernet: {len(padding)} padding bytes after the {name} message are not all zero"
            )
            if strict:
                raise InvalidFieldError(msg, field="padding", offset=head + used)
            findings.append(warning("eth.padding.nonzero", msg))
        if len(fill) > auto:
            msg = (
                f"Ethernet: {len(fill)} bytes follow the {used}-byte {name} message, "
                f"{auto} would pad to the minimum"
            )
            if strict:
                raise LengthMismatchError(msg, field="padding", offset=head + used)
            findings.append(info("eth.trailer", msg))
    return ethernet.EthernetFrame(dst, src, message, ethertype, pad, tuple(findings), tags)


T = TypeVar("T")
K = TypeVar("K", bound=Hashable)

# How many distinct frames a RepeatMemo remembers: a cycle's worth of distinct requests (EPL: 239
# PReq + SoA + ...; EtherCAT: a master's outgoing frames) fits many times over; about 6 MB
# for full-size frames, whatever the capture's length.
MEMO_ENTRIES: Final = 4096


class RepeatMemo(Generic[K, T]):
    """A pure function of a frame's bytes, computed once for frames that repeat byte for byte.

    Cyclic captures repeat most frames exactly: an EPL MN's PReq and SoA, an EtherCAT master's
    outgoing frames. Decoded frames are immutable, so a repeat can share the first result. The
    memory is bounded: past ``MEMO_ENTRIES`` distinct keys it starts afresh. ``key`` (default:
    the argument itself) may map arguments whose results the caller treats as equal to one key.
    """

    def __init__(
        self,
        compute: Callable[[K], T],
        entries: int = MEMO_ENTRIES,
        key: Callable[[K], Hashable] | None = None,
    ) -> None:
        self._compute = compute
        self._entries = entries
        self._key = key
        self._memo: dict[Hashable, T] = {}

    def __call__(self, arg: K) -> T:
        """``compute(arg)``, remembered under ``key(arg)``."""
        k = arg if self._key is None else self._key(arg)
        try:
            return self._memo[k]
        except KeyError:
            pass
        value = self._compute(arg)  # raises as compute raises; nothing remembered then
        if len(self._memo) >= self._entries:
            self._memo.clear()
        self._memo[k] = value
        return value


def _raw(data: bytes, head: int = ethernet.HEADER_BYTES) -> tuple[bytes, bytes]:
    """(payload, trailer) of a frame kept as raw bytes: the payload stops at 1500 bytes."""
    body = data[head:]
    return body[: ethernet.MAX_PAYLOAD_BYTES], body[ethernet.MAX_PAYLOAD_BYTES :]
