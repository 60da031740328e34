"""``skinframes sii``: build an SII EEPROM image from an ESI file, or decode an image."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from skinframes.atomic_file import check_target
from skinframes.errors import DecodeError, SkinframesError
from skinframes.esi import (
    EsiModule,
    EsiPdo,
    EsiSlots,
    missing_communication_objects,
    parse_esi,
)
from skinframes.sii import (
    DecodedSii,
    FmmuUsage,
    MailboxProtocol,
    SiiPdo,
    SyncManagerType,
    decode_sii,
    encode_sii,
    sii_from_esi,
)
from skinframes.text import escape
from skinframes_cli.options import in_path
from skinframes_cli.streams import STDIO, input_bytes, output


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "sii",
        help="build an SII EEPROM image from an ESI file, or decode an image",
        description="With an ESI XML file (ETG.2000): write the SII EEPROM image (ETG.2010) of "
        "one of its devices to --out, or print it as JSON (--json). With an image: print what "
        "it holds (--json for JSON).",
    )
    p.add_argument(
        "path",
        metavar="FILE",
        type=in_path,
        help="an ESI .xml file, or an SII image to decode; - for stdin",
    )
    p.add_argument(
        "--device",
        metavar="TYPE",
        help="the device: its Type text or product code, optionally @REVISION",
    )
    p.add_argument(
        "--out", metavar="FILE", help="the image file to write (ESI input); - for stdout"
    )
    p.add_argument(
        "--force", action="store_true", help="replace an --out file that is not an SII image"
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="one JSON document: the image's (ESI input: of the image built, with its device)",
    )
    p.set_defaults(run=run)


def _is_xml(data: bytes) -> bool:
    return data.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"<")


def run(args: argparse.Namespace) -> int:
    """Build or decode."""
    data = input_bytes(args.path)
    if _is_xml(data):
        if args.out is None and not args.json:
            raise SkinframesError(
                f"{args.path}: an ESI file; --out FILE names the image to write, --json prints it"
            )
        if args.json and args.out == STDIO:
            raise SkinframesError("--json with --out -: both on stdout; write the image to a file")
        return _build(args, data)
    if args.out is not None or args.device is not None:
        raise SkinframesError(f"{args.path}: not an ESI XML file; --out and --device need one")
    decoded = decode_sii(data)
    if args.json:
        print(json.dumps(to_json(decoded)))
    else:
        for line in to_text(decoded):
            print(line)
    return 0


def _build(args: argparse.Namespace, data: bytes) -> int:
    if args.out is not None:
        _check_out(args)
    esi = parse_esi(data, source=args.path)
    device = esi.device(args.device)
    built = sii_from_esi(esi, device)
    raw = encode_sii(built.image)
    if args.out is not None:
        with output(args.out, "wb", what="--out") as f:
            f.write(raw)
    for what in built.omitted:
        print(f"left out to fit ByteSize {built.image.eeprom_bytes}: {what}", file=sys.stderr)
    if args.out is not None:
        print(
            f"wrote {escape(args.out)}: {escape(device.type_name)}, {len(raw)} bytes",
            file=sys.stderr,
        )
    if args.json:
        doc = to_json(decode_sii(raw))
        dictionary = device.dictionary
        doc["esi"] = {
            "type": device.type_name,
            "objects": None if dictionary is None else len(dictionary.objects),
            "left_out": list(built.omitted),
            "added_objects": list(missing_communication_objects(device)),
            "slots": _slots(device.slots),
            "modules": [_module(m) for m in esi.slot_modules(device)],
        }
        print(json.dumps(doc))
    return 0


def _slots(slots: EsiSlots | None) -> dict[str, Any] | None:
    """A modular device's ``Slots`` as the ESI gives them (None: not modular)."""
    if slots is None:
        return None
    return {
        "slot_index_increment": slots.slot_index_increment,
        "slot_pdo_increment": slots.slot_pdo_increment,
        "max_slot_count": slots.max_slot_count,
        "download_module_ident_list": slots.download_module_ident_list,
        "slots": [
            {
                "name": s.name,
                "min_instances": s.min_instances,
                "max_instances": s.max_instances,
                "module_idents": list(s.module_idents),
                "default_module_ident": s.default_module_ident,
                "module_classes": list(s.module_classes),
                "slot_index_increment": s.slot_index_increment,
                "slot_pdo_increment": s.slot_pdo_increment,
            }
            for s in slots.slots
        ],
    }


def _esi_pdos(pdos: tuple[EsiPdo, ...]) -> list[dict[str, Any]]:
    """A module's PDOs as the ESI gives them (the SII has no place for them)."""
    return [
        {
            "index": p.index,
            "sm": p.sync_manager,
            "name": p.name,
            "depend_on_slot": p.depend_on_slot,
            "entries": [
                {
                    "index": e.index,
                    "subindex": e.subindex,
                    "bits": e.bit_length,
                    "data_type": e.data_type,
                    "name": e.name,
                    "depend_on_slot": e.depend_on_slot,
                }
                for e in p.entries
            ],
        }
        for p in pdos
    ]


def _module(m: EsiModule) -> dict[str, Any]:
    return {
        "module_ident": m.module_ident,
        "type": m.type_name,
        "name": m.name,
        "module_class": m.module_class,
        "module_pdo_group": m.module_pdo_group,
        "txpdos": _esi_pdos(m.tx_pdos),
        "rxpdos": _esi_pdos(m.rx_pdos),
        "objects": None if m.dictionary is None else len(m.dictionary.objects),
    }


def _check_out(args: argparse.Namespace) -> None:
    """Refuse an empty --out, a symbolic link, and a file that is not an SII image already
    (unless --force)."""
    if not args.out:
        raise SkinframesError("--out: an empty name")
    if args.out == STDIO:
        return
    out = Path(args.out)
    check_target(out)
    if out.exists() and not args.force:
        try:
            decode_sii(out.read_bytes())
        except DecodeError:
            raise SkinframesError(
                f"{args.out}: exists and is not an SII image; move it away or use --force"
            ) from None


def _name(kind: type[FmmuUsage] | type[SyncManagerType], value: int) -> str:
    try:
        return kind(value).name.lower()
    except ValueError:
        return str(value)


def _pdos(pdos: tuple[SiiPdo, ...], strings: Any) -> list[dict[str, Any]]:
    return [
        {
            "index": p.index,
            "sm": p.sync_manager,
            "name": strings(p.name_index),
            "flags": p.flags,
            "entries": [
                {
                    "index": e.index,
                    "subindex": e.subindex,
                    "bits": e.bit_length,
                    "data_type": e.data_type,
                    "name": strings(e.name_index),
                }
                for e in p.entries
            ],
        }
        for p in pdos
    ]


def to_json(decoded: DecodedSii) -> dict[str, Any]:
    """The ``sii --json`` document of a decoded image."""
    img = decoded.image
    g = img.general
    return {
        "vendor_id": img.vendor_id,
        "product_code": img.product_code,
        "revision": img.revision,
        "serial": img.serial,
        "alias": img.alias,
        "config_data": img.config_data.hex(),
        "checksum": decoded.checksum,
        "eeprom_bytes": img.eeprom_bytes,
        "version": img.version,
        "bootstrap_mailboxes": [list(img.bootstrap_rx_mailbox), list(img.bootstrap_tx_mailbox)],
        "standard_mailboxes": [list(img.standard_rx_mailbox), list(img.standard_tx_mailbox)],
        "mailbox_protocols": [p.name.lower() for p in MailboxProtocol if img.mailbox_protocols & p],
        "strings": list(img.strings),
        "name": img.string(g.name_index) if g else "",
        "coe_details": g.coe_details if g else 0,
        "syncmanagers": [
            {
                "start": s.start,
                "length": s.length,
                "control": s.control,
                "enable": s.enable,
                "type": _name(SyncManagerType, s.type),
            }
            for s in img.sync_managers
        ],
        "fmmus": [_name(FmmuUsage, f) for f in img.fmmus],
        "txpdos": _pdos(img.tx_pdos, img.string),
        "rxpdos": _pdos(img.rx_pdos, img.string),
        "dc": [
            {
                "assign_activate": d.assign_activate,
                "cycle_time_0_ns": d.cycle_time_0_ns,
                "shift_time_0_ns": d.shift_time_0_ns,
                "shift_time_1_ns": d.shift_time_1_ns,
                "name": img.string(d.name_index),
            }
            for d in img.dc
        ],
        "other_categories": [c.category_type for c in img.other_categories],
        "findings": [f.to_json() for f in decoded.findings],
    }


def to_text(decoded: DecodedSii) -> list[str]:
    """The text listing of a decoded image."""
    doc = to_json(decoded)
    lines = [
        f"vendor {doc['vendor_id']:#010x}  product {doc['product_code']:#010x}  "
        f"revision {doc['revision']:#010x}  serial {doc['serial']}  alias {doc['alias']}",
        f"name {escape(doc['name'])!s}  EEPROM {doc['eeprom_bytes']} bytes  version "
        f"{doc['version']}  config {doc['config_data']}  checksum {doc['checksum'] & 0xFF:#04x}",
        f"mailboxes: standard {doc['standard_mailboxes']}  bootstrap "
        f"{doc['bootstrap_mailboxes']}  protocols {','.join(doc['mailbox_protocols']) or '-'}",
    ]
    for i, s in enumerate(doc["syncmanagers"]):
        lines.append(
            f"SM{i}: start {s['start']:#06x} length {s['length']} control {s['control']:#04x} "
            f"enable {s['enable']} {s['type']}"
        )
    lines += [f"FMMU{i}: {f}" for i, f in enumerate(doc["fmmus"])]
    for kind, label in (("txpdos", "TxPDO"), ("rxpdos", "RxPDO")):
        for p in doc[kind]:
            entries = " ".join(
                f"{e['index']:#06x}:{e['subindex']}/{e['bits']}" for e in p["entries"]
            )
            lines.append(f"{label} {p['index']:#06x} SM{p['sm']} {escape(p['name'])}: {entries}")
    lines += [
        f"DC op mode {escape(d['name'])}: assign {d['assign_activate']:#06x}" for d in doc["dc"]
    ]
    lines += [f"string {i + 1}: {escape(s)}" for i, s in enumerate(doc["strings"])]
    lines += [f"{f['severity']}: {f['code']}: {f['message']}" for f in doc["findings"]]
    return lines
