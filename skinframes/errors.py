"""The one exception tree of skinframes.

Every error the library raises on bad input comes from here::

    SkinframesError(Exception)          .field (dotted path), .offset (byte index)
    ├── DecodeError(…, ValueError)      bytes -> model
    │   ├── TruncatedError              fewer bytes than the header or length says
    │   ├── InvalidFieldError           reserved bits set, bad constant, unknown enum value
    │   ├── LengthMismatchError         a length field disagrees with the buffer; leftover bytes
    │   ├── ChecksumError               FCS / CRC
    │   ├── UnknownProtocolError        unregistered EtherType / link type
    │   ├── PcapFormatError             bad magic, version, truncated record
    │   ├── CanLogFormatError           not a readable CAN log (unknown suffix, damaged);
    │   │                               its old name TraceFormatError is the same class
    │   └── EsiFormatError              an ESI XML file that cannot be used (malformed, an
    │                                   element missing or unusable: named with its line)
    └── EncodeError(…, ValueError)      model -> bytes
        ├── FieldRangeError             a value does not fit its field (11-bit length > 2047, node id > 255)
        ├── FrameTooLargeError          > 1500-byte payload, too many datagrams
        ├── UnsupportedFormatError      a CAN trace format that cannot hold a frame as given
        └── CaptureError                a capture file that cannot be written as asked (path
                                        refused, a mark classic pcap cannot carry, arrays disagree)
    InterfaceError                      a live capture cannot start: no such interface, not
                                        root / no CAP_NET_RAW, not Linux
    (emulator.errors.EmulatorError continues the tree: TopologyError, ScheduleError, LinkError)

Wrong argument *types* stay ``TypeError``. construct's and python-can's exceptions never escape:
:func:`decoding` and :func:`encoding` re-raise them as ours, chained with ``from``.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from contextlib import contextmanager

import construct as cs

__all__ = [
    "CanLogFormatError",
    "CaptureError",
    "ChecksumError",
    "DecodeError",
    "EncodeError",
    "EsiFormatError",
    "FieldRangeError",
    "FrameTooLargeError",
    "InterfaceError",
    "InvalidFieldError",
    "LengthMismatchError",
    "PcapFormatError",
    "SkinframesError",
    "TraceFormatError",
    "TruncatedError",
    "UnknownProtocolError",
    "UnsupportedFormatError",
    "decoding",
    "encoding",
]


class SkinframesError(Exception):
    """Root of every error skinframes raises on bad input.

    Args:
        message: what went wrong, with expected and found values.
        field: dotted path of the offending field, when known (``"datagram[2].length"``).
        offset: byte index into the input, when known.
    """

    def __init__(self, message: str, *, field: str | None = None, offset: int | None = None):
        super().__init__(message)
        self.field = field
        self.offset = offset


class DecodeError(SkinframesError, ValueError):
    """Bytes could not be turned into a model."""


class TruncatedError(DecodeError):
    """Fewer bytes than a header or length field announces."""


class InvalidFieldError(DecodeError):
    """A reserved bit is set, a constant differs, or an enum value is unknown."""


class LengthMismatchError(DecodeError):
    """A length field disagrees with the buffer, or bytes are left over."""


class ChecksumError(DecodeError):
    """A frame check sequence or CRC does not match."""


class UnknownProtocolError(DecodeError):
    """An EtherType or link type that skinframes does not decode."""


class PcapFormatError(DecodeError):
    """A capture file is not a readable pcap / pcapng (magic, version, record header)."""


class CanLogFormatError(DecodeError):
    """A file is not a readable CAN log: unknown suffix, unreadable, or damaged from the start."""


TraceFormatError = CanLogFormatError  # its old name (docs/interface.md, Old names)


class EsiFormatError(DecodeError):
    """An EtherCAT Slave Information (ESI) file cannot be used.

    Not well-formed XML, a required element missing, or a value that is not what ETG.2000
    allows; the message names the element and its line. Also raised when a device asked for is
    not in the file.
    """


class EncodeError(SkinframesError, ValueError):
    """A model could not be turned into bytes."""


class FieldRangeError(EncodeError):
    """A value does not fit the width of its field."""


class FrameTooLargeError(EncodeError):
    """The encoded frame exceeds the protocol's maximum size."""


class UnsupportedFormatError(EncodeError):
    """A trace format cannot be written, or cannot hold a frame as given."""


class CaptureError(EncodeError):
    """A capture file cannot be written as asked.

    The path is refused (a symlink, a directory, a missing directory), a record carries what the
    format cannot hold (a comment or CRC mark in classic pcap), or the arrays of a block disagree.
    """


@contextmanager
def decoding(what: str) -> Iterator[None]:
    """Re-raise construct and builtin decoding failures as :class:`DecodeError` subclasses.

    Args:
        what: the thing being decoded, prefixed to the message (``"EtherCAT datagram"``).
    """
    try:
        yield
    except SkinframesError:
        raise
    except cs.StreamError as exc:  # ran out of bytes
        raise TruncatedError(f"{what}: truncated ({exc})", field=_path(exc)) from exc
    except cs.ConstructError as exc:
        raise InvalidFieldError(f"{what}: {exc}", field=_path(exc)) from exc
    except (ValueError, IndexError, KeyError) as exc:
        raise InvalidFieldError(f"{what}: {exc}") from exc


@contextmanager
def encoding(what: str) -> Iterator[None]:
    """Re-raise construct and builtin encoding failures as :class:`EncodeError` subclasses."""
    try:
        yield
    except SkinframesError:
        raise
    except (cs.ConstructError, OverflowError, ValueError, struct.error) as exc:
        raise FieldRangeError(f"{what}: {exc}", field=_path(exc)) from exc


def _path(exc: Exception) -> str | None:
    path = getattr(exc, "path", None)
    if not path:
        return None
    return str(path).replace("(parsing) -> ", "").replace("(building) -> ", "").replace(" -> ", ".")


class InterfaceError(SkinframesError):
    """A live capture cannot start on the network interface asked for: there is no such
    interface, the process lacks root or CAP_NET_RAW, or the system has no AF_PACKET (not
    Linux)."""
