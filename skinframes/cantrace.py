"""Old path of :mod:`skinframes.canbus.log` (CAN log files: python-can's formats, SocketCAN pcap).

The module moved into the ``skinframes.canbus`` package; this one re-exports its names so that
scripts written against ``skinframes.cantrace`` keep working. New code imports
``skinframes.canbus.log``.
"""

from skinframes.canbus.log import NS_PER_S as NS_PER_S
from skinframes.canbus.log import (
    PCAP_SUFFIXES,
    TRACE_SUFFIXES,
    Trace,
    TraceFormatError,
    UnsupportedFormatError,
    from_message,
    read_frames,
    read_trace,
    to_message,
    trace_format,
    write_trace,
)
from skinframes.canbus.log import TEXT_SUFFIXES as TEXT_SUFFIXES

__all__ = [
    "PCAP_SUFFIXES",
    "TRACE_SUFFIXES",
    "Trace",
    "TraceFormatError",
    "UnsupportedFormatError",
    "from_message",
    "read_frames",
    "read_trace",
    "to_message",
    "trace_format",
    "write_trace",
]
