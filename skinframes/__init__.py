"""skinframes: the bytes of robot-skin fieldbus frames (EPL, EtherCAT, legacy CAN).

The public API::

    from skinframes import read_capture, decode_frame
    for rec in read_capture("x.pcapng"):
        frame = decode_frame(rec.data)
        assert frame.to_bytes() == rec.data
"""

from skinframes.capture_taxels import CaptureTaxels, taxels_from_capture
from skinframes.dispatch import decode_frame, protocol_of
from skinframes.errors import DecodeError, EncodeError, SkinframesError
from skinframes.ethercat import Command, Datagram, EcatFrame
from skinframes.ethernet import EthernetFrame
from skinframes.findings import Finding, Severity
from skinframes.pcap import Capture, CaptureWriter, PcapWriter, Record, read_capture, write_pcap

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
