"""Old path of :mod:`skinframes.canbus.log` (CAN log files: python-can's formats, SocketCAN pcap).

The module moved into the ``skinframes.canbus`` package; this one re-exports its names (its
``__all__`` and its public constants) so that scripts written against ``skinframes.cantrace`` keep
working. New code imports ``skinframes.canbus.log``, where the CAN log's names replace the old
"trace" ones, which stay as aliases: ``Trace`` = ``CanLog``, ``read_trace`` = ``read_can_log``,
``write_trace`` = ``write_can_log``, ``trace_format`` = ``can_log_format``, ``TRACE_SUFFIXES`` =
``PYTHON_CAN_SUFFIXES``.
"""

from skinframes.canbus import log as _new
from skinframes.canbus.log import MAX_LISTED_DAMAGE as MAX_LISTED_DAMAGE
from skinframes.canbus.log import NS_PER_S as NS_PER_S
from skinframes.canbus.log import PCAP_SUFFIXES as PCAP_SUFFIXES
from skinframes.canbus.log import PYTHON_CAN_SUFFIXES as PYTHON_CAN_SUFFIXES
from skinframes.canbus.log import STREAM_SUFFIXES as STREAM_SUFFIXES
from skinframes.canbus.log import TEXT_SUFFIXES as TEXT_SUFFIXES
from skinframes.canbus.log import TRACE_SUFFIXES as TRACE_SUFFIXES
from skinframes.canbus.log import CanLog as CanLog
from skinframes.canbus.log import CanLogFormatError as CanLogFormatError
from skinframes.canbus.log import CanLogReader as CanLogReader
from skinframes.canbus.log import RecordCounts as RecordCounts
from skinframes.canbus.log import Trace as Trace
from skinframes.canbus.log import TraceFormatError as TraceFormatError
from skinframes.canbus.log import UnsupportedFormatError as UnsupportedFormatError
from skinframes.canbus.log import can_log_format as can_log_format
from skinframes.canbus.log import from_message as from_message
from skinframes.canbus.log import read_can_log as read_can_log
from skinframes.canbus.log import read_frames as read_frames
from skinframes.canbus.log import read_trace as read_trace
from skinframes.canbus.log import to_message as to_message
from skinframes.canbus.log import trace_format as trace_format
from skinframes.canbus.log import write_can_log as write_can_log
from skinframes.canbus.log import write_trace as write_trace

__all__ = list(_new.__all__)  # what `import *` gave before, from the one list
