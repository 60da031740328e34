"""``skinframes decode PATH [--json]``: every frame of a capture, as text or JSON Lines."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from skinframes.canwire import CanFrame
from skinframes.describe import frame_fields, summary
from skinframes.dispatch import decode_frame, protocol_of
from skinframes.errors import DecodeError, TruncatedError
from skinframes.pcap import LINKTYPE_CAN_SOCKETCAN, LINKTYPE_ETHERNET, read_capture


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "decode",
        help="decode every frame of a pcap/pcapng (gzip too)",
        description="Decode every frame of a pcap or pcapng file (gzip too). "
        "Skipped records are reported on stderr with their reason.",
    )
    p.add_argument("path", help="capture file")
    p.add_argument("--json", action="store_true", help="JSON Lines: one object per frame")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Decode and print."""
    capture = read_capture(args.path)
    out = sys.stdout
    for rec in capture:
        obj: dict[str, Any] = {"index": rec.index, "time_ns": rec.time_ns, "length": len(rec.data)}
        if rec.linktype == LINKTYPE_CAN_SOCKETCAN:
            fields, text = _can_fields(rec.data)
            obj.update(protocol="can", linktype=rec.linktype, **fields)
        elif rec.linktype != LINKTYPE_ETHERNET:
            obj.update(protocol="other", linktype=rec.linktype, findings=[])
            text = f"linktype {rec.linktype}, {len(rec.data)} bytes"
        else:
            try:
                frame = decode_frame(rec.data)
            except DecodeError as exc:
                obj.update(
                    protocol="other",
                    findings=[{"severity": "error", "code": "eth.truncated", "message": str(exc)}],
                )
                text = str(exc)
            else:
                obj["protocol"] = protocol_of(frame)
                obj.update(frame_fields(frame))
                obj["findings"] = [f.to_json() for f in frame.findings]
                text = summary(frame)
        if args.json:
            out.write(json.dumps(obj) + "\n")
        else:
            sec, ns = divmod(rec.time_ns, 1_000_000_000)  # exact: a float has no room for ns
            out.write(f"{rec.index:>6} {f'{sec}.{ns:09d}':>20} {len(rec.data):>5}  {text}\n")
    for s in capture.skipped:
        print(f"skinframes: skipped record {s.index}: {s.reason}", file=sys.stderr)
    print(
        f"skinframes: {capture.total} records: {len(capture.records)} decoded, "
        f"{len(capture.skipped)} skipped",
        file=sys.stderr,
    )
    return 0


def _can_fields(data: bytes) -> tuple[dict[str, Any], str]:
    """JSON fields and a text line for a SocketCAN record (LINKTYPE 227)."""
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
