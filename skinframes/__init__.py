"""skinframes: the bytes of robot-skin fieldbus frames (EPL, EtherCAT, legacy CAN).

The public API::

    from skinframes import read_capture, decode_frame
    for rec in read_capture("x.pcapng"):
        frame = decode_frame(rec.data)
        assert frame.to_bytes() == rec.data
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from skinframes.capture_taxels import CaptureTaxels, taxels_from_capture
    from skinframes.dispatch import decode_frame, protocol_of
    from skinframes.errors import DecodeError, EncodeError, SkinframesError
    from skinframes.ethercat import Command, Datagram, EcatFrame
    from skinframes.ethernet import EthernetFrame
    from skinframes.findings import Finding, Severity
    from skinframes.pcap import (
        Capture,
        CaptureWriter,
        PcapWriter,
        Record,
        read_capture,
        write_pcap,
    )

__version__ = "0.1.0"

__all__ = [
    "Capture",
    "CaptureTaxels",
    "CaptureWriter",
    "Command",
    "Datagram",
    "DecodeError",
    "EcatFrame",
    "EncodeError",
    "EthernetFrame",
    "Finding",
    "PcapWriter",
    "Record",
    "Severity",
    "SkinframesError",
    "decode_frame",
    "protocol_of",
    "read_capture",
    "taxels_from_capture",
    "write_pcap",
]

# Package-level name -> the module that defines it. Imported on first use (PEP 562), so that
# ``import skinframes.errors`` (every command line start) does not load numpy and the schemas.
_WHERE: dict[str, str] = {
    "CaptureTaxels": "capture_taxels",
    "taxels_from_capture": "capture_taxels",
    "decode_frame": "dispatch",
    "protocol_of": "dispatch",
    "DecodeError": "errors",
    "EncodeError": "errors",
    "SkinframesError": "errors",
    "Command": "ethercat",
    "Datagram": "ethercat",
    "EcatFrame": "ethercat",
    "EthernetFrame": "ethernet",
    "Finding": "findings",
    "Severity": "findings",
    "Capture": "pcap",
    "CaptureWriter": "pcap",
    "PcapWriter": "pcap",
    "Record": "pcap",
    "read_capture": "pcap",
    "write_pcap": "pcap",
}
assert sorted(_WHERE) == sorted(__all__)

if not TYPE_CHECKING:  # mypy reads the imports above; an unknown name stays an error for it

    def __getattr__(name: str) -> Any:
        """A public name, or a submodule (``skinframes.ethercat`` after ``import skinframes``),
        imported when first asked for."""
        where = _WHERE.get(name)
        if where is None:
            try:
                return importlib.import_module(f"{__name__}.{name}")
            except ModuleNotFoundError as exc:
                if exc.name != f"{__name__}.{name}":
                    raise
                raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(f"{__name__}.{where}"), name)
        globals()[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*globals(), *__all__})
