"""EtherType -> payload decoder: the one place that knows which protocols skinframes decodes."""

from __future__ import annotations

from collections.abc import Callable
from typing import Final, Literal

from skinframes import ethercat, ethernet, powerlink
from skinframes.errors import (
    DecodeError,
    InvalidFieldError,
    LengthMismatchError,
    TruncatedError,
    UnknownProtocolError,
)
from skinframes.findings import Finding, error, info, warning

__all__ = ["DECODERS", "decode_frame", "protocol_of"]

Decoder = Callable[..., tuple[ethernet.Payload, int, list[Finding]]]

DECODERS: Final[dict[int, Decoder]] = {
    ethernet.ETHERTYPE_EPL: powerlink.decode,
    ethernet.ETHERTYPE_ECAT: ethercat.decode,
}

PROTOCOL_NAMES: Final = {ethernet.ETHERTYPE_EPL: "epl", ethernet.ETHERTYPE_ECAT: "ecat"}


def protocol_of(frame: ethernet.EthernetFrame) -> Literal["epl", "ecat", "other"]:
    """``"epl"`` or ``"ecat"`` when the payload was decoded as such, else ``"other"``."""
    if isinstance(frame.payload, ethercat.EcatFrame):
        return "ecat"
    if isinstance(frame.payload, bytes | bytearray):
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
    payload = data[ethernet.HEADER_BYTES :]
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
    if decoder is None:
        if strict:
            raise UnknownProtocolError(
                f"Ethernet: EtherType {ethertype:#06x} is not EPL or EtherCAT"
            )
        body, trailer = _raw(data)
        return ethernet.EthernetFrame(dst, src, body, ethertype, trailer, tuple(findings))
    name = PROTOCOL_NAMES[ethertype]
    try:
        message, used, more = decoder(payload, strict=strict)
        if used > ethernet.MAX_PAYLOAD_BYTES:
            raise LengthMismatchError(
                f"Ethernet: the {used}-byte {name} message exceeds the "
                f"{ethernet.MAX_PAYLOAD_BYTES}-byte maximum payload",
                field="payload",
                offset=ethernet.HEADER_BYTES,
            )
    except DecodeError as exc:
        if strict:
            raise
        findings.append(error(f"{name}.undecodable", f"{exc}; kept as raw bytes"))
        body, trailer = _raw(data)
        return ethernet.EthernetFrame(dst, src, body, ethertype, trailer, tuple(findings))
    findings += more
    padding = payload[used:]
    auto = ethernet.padding_for(ethernet.HEADER_BYTES + used)
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
                raise InvalidFieldError(msg, field="padding", offset=ethernet.HEADER_BYTES + used)
            findings.append(warning("eth.padding.nonzero", msg))
        if len(fill) > auto:
            msg = (
                f"Ethernet: {len(fill)} bytes follow the {used}-byte {name} message, "
                f"{auto} would pad to the minimum"
            )
            if strict:
                raise LengthMismatchError(msg, field="padding", offset=ethernet.HEADER_BYTES + used)
            findings.append(info("eth.trailer", msg))
    return ethernet.EthernetFrame(dst, src, message, ethertype, pad, tuple(findings))


def _raw(data: bytes) -> tuple[bytes, bytes]:
    """(payload, trailer) of a frame kept as raw bytes: the payload stops at 1500 bytes."""
    body = data[ethernet.HEADER_BYTES :]
    return body[: ethernet.MAX_PAYLOAD_BYTES], body[ethernet.MAX_PAYLOAD_BYTES :]
