"""Old path of :mod:`skinframes.canbus.log` (CAN log files: python-can's formats, SocketCAN pcap).

The module moved into the ``skinframes.canbus`` package; this one re-exports its names so that
scripts written against ``skinframes.cantrace`` keep working. New code imports
``skinframes.canbus.log``, where the CAN log's names replace the old "trace" ones, which stay as
aliases: ``Trace`` = ``CanLog``, ``read_trace`` = ``read_can_log``, ``write_trace`` =
``write_can_log``, ``trace_format`` = ``can_log_format``, ``TRACE_SUFFIXES`` =
``PYTHON_CAN_SUFFIXES``.
"""

from skinframes.canbus.log import NS_PER_S as NS_PER_S
from skinframes.canbus.log import (
    PCAP_SUFFIXES,
    PYTHON_CAN_SUFFIXES,
    TRACE_SUFFIXES,
    CanLog,
    Trace,
    TraceFormatError,
    UnsupportedFormatError,
    can_log_format,
    from_message,
    read_can_log,
    read_frames,
    read_trace,
    to_message,
    trace_format,
    write_can_log,
    write_trace,
)
from skinframes.canbus.log import TEXT_SUFFIXES as TEXT_SUFFIXES

__all__ = [
    "PCAP_SUFFIXES",
    "PYTHON_CAN_SUFFIXES",
    "TRACE_SUFFIXES",
    "CanLog",
    "Trace",
    "TraceFormatError",
    "UnsupportedFormatError",
    "can_log_format",
    "from_message",
    "read_can_log",
    "read_frames",
    "read_trace",
    "to_message",
    "trace_format",
    "write_can_log",
    "write_trace",
]
