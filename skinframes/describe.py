"""Human and JSON views of decoded frames and capture records, used by ``skinframes decode``.

Field names in the JSON are skinframes' (snake_case spec names); ``tests/conformance/fields.py``
maps them to tshark's. Where Wireshark names a field skinframes had no key for (the EPL flag bits,
the SDO pad size), the key is Wireshark's name: ``fls`` for ``epl.pres.fls``, ``sdo_data_padding``
for ``epl.asnd.sdo.cmd.data.padding``.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import Any

from skinframes import encap, ethercat, ethernet, ipv4udp, powerlink
from skinframes.dispatch import RepeatMemo, decode_frame, protocol_of
from skinframes.errors import DecodeError, TruncatedError
from skinframes.pcap import LINKTYPE_CAN_SOCKETCAN, LINKTYPE_ETHERNET, Record
from skinframes.powerlink.enums import (
    PREQ_FLAG_BITS,
    PRES_FLAG_BITS,
    RESPONSE_FLAG_BITS,
    SOA_FLAG_BITS,
    SOC_FLAG_BITS,
    flag_bits,
)
from skinframes.powerlink.services import multi_param_entries

__all__ = ["JsonDescriber", "describe_record", "frame_fields", "record_json", "summary"]


def _name(value: int, enum: type[IntEnum]) -> str:
    try:
        return enum(value).name
    except ValueError:
        return f"{value:#04x}"


def frame_fields(frame: ethernet.EthernetFrame) -> dict[str, Any]:
    """The protocol fields of a decoded frame as JSON-ready values."""
    out: dict[str, Any] = {
        "eth_dst": ethernet.format_mac(frame.dst),
        "eth_src": ethernet.format_mac(frame.src),
        "ethertype": frame.ethertype,
    }
    out.update(encap.fields(frame))  # VLAN tags, IPv4/UDP: empty for a plain frame
    p = encap.message_of(frame)
    if isinstance(p, ethercat.EcatFrame):
        out["ecat_length"] = p.length_field
        out["ecat_type"] = p.frame_type
        out.update(ethercat.content_fields(p))  # types 4 and 5: nv / mailbox
        out["datagrams"] = [
            {
                "cmd": _name(d.cmd, ethercat.Command),
                "cmd_code": int(d.cmd),
                "idx": d.idx,
                "adp": d.adp,
                "ado": d.ado,
                "lad": d.lad,
                "length": d.length,
                "circulating": d.circulating,
                "irq": d.irq,
                "wkc": d.wkc,
            }
            for d in p.datagrams
        ]
    elif isinstance(p, bytes | bytearray):
        out["payload_length"] = len(p)
    else:
        out.update(_epl_fields(p))
        _udp_nodes(frame, out)
    return out


def _udp_nodes(frame: ethernet.EthernetFrame, fields: dict[str, Any]) -> None:
    """EPL over UDP: ``src``/``dest`` are the node ids of the IP addresses (DS 301 5.1.2), as
    Wireshark shows them; bytes 1-2, where the message keeps them, are reserved there."""
    packet = frame.payload
    if isinstance(packet, ipv4udp.Ipv4Udp):
        fields["src"], fields["dest"] = packet.src_node, packet.dest_node


_MESSAGE_NAMES: dict[int, str] = {int(t): t.name for t in powerlink.MessageType}


@dataclass(frozen=True, slots=True)
class _AinvFlags:
    """Byte 4 of an AInv, kept as bytes: it has the SoA's layout (DS 302-A), and Wireshark shows
    its flags as ``epl.soa.*``."""

    flags1: int


def _epl_fields(m: Any) -> dict[str, Any]:
    """The JSON fields of an EPL message; one type test per message, not one per field group."""
    kind = type(m)
    if kind is powerlink.RawMessage:
        raw = {
            "message_type": m.message_type & 0x7F,
            "message": _name(m.message_type & 0x7F, powerlink.MessageType),
            "dest": m.dest,
            "src": m.src,
            "data_length": len(m.data),
        }
        if raw["message_type"] == powerlink.MessageType.AINV and len(m.data) >= 2:
            raw["flags1"] = m.data[1]
            raw.update(flag_bits(_AinvFlags(m.data[1]), SOA_FLAG_BITS))
        return raw
    out: dict[str, Any] = {
        "message_type": int(m.MESSAGE_TYPE),
        "message": _MESSAGE_NAMES[m.MESSAGE_TYPE],
        "dest": m.dest,
        "src": m.src,
    }
    if kind is powerlink.PRes or kind is powerlink.PReq:
        out["size"] = len(m.payload)
        out["pdo_version"] = m.pdo_version
        out["flags1"] = int(m.flags1)
        out["flags2"] = int(m.flags2)
        if kind is powerlink.PRes:
            out["nmt_status"] = int(m.nmt_status)
            out.update(flag_bits(m, PRES_FLAG_BITS))
        else:
            out.update(flag_bits(m, PREQ_FLAG_BITS))
    elif kind is powerlink.SoA:
        out["nmt_status"] = int(m.nmt_status)
        out["requested_service"] = int(m.requested_service)
        out["requested_target"] = m.requested_target
        out["epl_version"] = m.epl_version
        out["flags1"] = int(m.flags1)
        out.update(flag_bits(m, SOA_FLAG_BITS))
    elif kind is powerlink.SoC:
        out["net_time_s"] = m.net_time_s
        out["net_time_ns"] = m.net_time_ns
        out["relative_time_us"] = m.relative_time_us
        out["flags"] = int(m.flags)
        out.update(flag_bits(m, SOC_FLAG_BITS))
    elif kind is powerlink.ASnd:
        out["service_id"] = m.service_id
        out["service"] = _name(m.service_id, powerlink.ServiceId)
        s = m.service
        if isinstance(s, powerlink.NmtCommand):
            out["command_id"] = int(s.command_id)
        if isinstance(s, powerlink.IdentResponse | powerlink.StatusResponse):
            out["nmt_status"] = int(s.nmt_status)
            out["flags1"] = int(s.flags1)
            out["flags2"] = int(s.flags2)
            out.update(flag_bits(s, RESPONSE_FLAG_BITS))
        if isinstance(s, powerlink.Sdo) and s.command is not None:
            out["sdo_command_id"] = s.command.command_id
            out["sdo_segment_size"] = len(s.command.data)
            entries = multi_param_entries(s.command)
            if entries:
                out["sdo_data_padding"] = [e.pad_size for e in entries]
    return out


def summary(frame: ethernet.EthernetFrame) -> str:
    """A one-line description in the spirit of Wireshark's Info column."""
    p = encap.message_of(frame)
    proto = protocol_of(frame)
    if proto == "ecat":
        assert isinstance(p, ethercat.EcatFrame)
        parts = [
            f"'{_name(d.cmd, ethercat.Command)}' len {d.length} wkc {d.wkc}" for d in p.datagrams
        ]
        shown = ", ".join(parts[:4]) + (f", ... ({len(parts)} datagrams)" if len(parts) > 4 else "")
        return f"ECAT {shown}"
    if proto == "other":
        return f"ethertype {frame.ethertype:#06x}, {len(frame.payload_bytes)} bytes"
    f = _epl_fields(p)
    _udp_nodes(frame, f)
    text = f"EPL {f['src']:>3}->{f['dest']:>3} {f['message']}"
    if "size" in f:
        text += f" [{f['size']}]"
    if "requested_service" in f:
        text += f" ({_name(f['requested_service'], powerlink.RequestedService)})->{f['requested_target']}"
    if "service" in f:
        text += f" ({f['service']})"
    return text


def describe_record(rec: Record) -> tuple[dict[str, Any], str]:
    """One capture record as the ``decode --json`` object and the text of its ``decode`` line.

    The object: ``index``, ``time_ns``, ``length``, ``protocol`` (``epl``, ``ecat``, ``can``,
    ``other``), the protocol's fields, and ``findings``. Ethernet frames are decoded in capture
    mode; one too short for its header is ``other`` with an ``eth.truncated`` error finding.
    """
    fields, text = _fields(rec.linktype, rec.data, text=True)
    return _head(rec) | fields, text


def record_json(rec: Record) -> dict[str, Any]:
    """The ``decode --json`` object of :func:`describe_record`, without building its text line."""
    return _head(rec) | _fields(rec.linktype, rec.data, text=False)[0]


class JsonDescriber:
    """:func:`record_json` for a whole capture: a frame seen before (same bytes and linktype)
    shares the protocol fields computed the first time (the objects are only read, never
    changed); memory bounded as :class:`~skinframes.dispatch.RepeatMemo` bounds it."""

    def __init__(self) -> None:
        self._fields = RepeatMemo(self._compute)

    @staticmethod
    def _compute(key: tuple[int, bytes]) -> dict[str, Any]:
        return _fields(key[0], key[1], text=False)[0]

    def __call__(self, rec: Record) -> dict[str, Any]:
        """The ``decode --json`` object of ``rec``."""
        obj = _head(rec)
        obj.update(self._fields((rec.linktype, rec.data)))
        return obj


def _head(rec: Record) -> dict[str, Any]:
    return {"index": rec.index, "frame": rec.frame, "time_ns": rec.time_ns, "length": len(rec.data)}


def _fields(linktype: int, data: bytes, text: bool) -> tuple[dict[str, Any], str]:
    """The JSON fields after ``length`` (``protocol`` ... ``findings``) and, if ``text``, the line."""
    obj: dict[str, Any] = {}
    line = ""
    if linktype == LINKTYPE_CAN_SOCKETCAN:
        fields, line = _can_fields(data)
        obj.update(protocol="can", linktype=linktype, **fields)
    elif linktype != LINKTYPE_ETHERNET:
        obj.update(protocol="other", linktype=linktype, findings=[])
        line = f"linktype {linktype}, {len(data)} bytes"
    else:
        try:
            frame = decode_frame(data)
        except DecodeError as exc:
            obj.update(
                protocol="other",
                findings=[{"severity": "error", "code": "eth.truncated", "message": str(exc)}],
            )
            line = str(exc)
        else:
            obj["protocol"] = protocol_of(frame)
            obj.update(frame_fields(frame))
            obj["findings"] = [f.to_json() for f in frame.findings]
            if text:
                line = summary(frame)
    return obj, line


def _can_fields(data: bytes) -> tuple[dict[str, Any], str]:
    """JSON fields and a text line for a SocketCAN record (LINKTYPE 227)."""
    from skinframes.canbus import CanFrame  # here: an Ethernet capture never loads the CAN codec

    try:
        f = CanFrame.from_socketcan(data)
    except DecodeError as exc:
        code = "can.truncated" if isinstance(exc, TruncatedError) else "can.invalid"
        return {"findings": [{"severity": "error", "code": code, "message": str(exc)}]}, str(exc)
    bits = None if f.error or f.fd else f.bits()
    fields = {
        "can_id": f.arbitration_id,
        "extended": f.extended,
        "remote": f.remote,
        "error_frame": f.error,
        "fd": f.fd,
        "dlc": f.dlc_field,
        "data": f.data.hex(),
        "wire_bits": bits,
        "findings": [],
    }
    kind = "error frame" if f.error else "remote" if f.remote else "FD" if f.fd else "data"
    ident = f"{f.arbitration_id:08x}" if f.extended else f"{f.arbitration_id:03x}"
    text = f"CAN {ident} {kind} [{f.dlc_field}] {f.data.hex(' ')}".rstrip()
    return fields, text
