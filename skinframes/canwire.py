"""Old path of :mod:`skinframes.canbus.wire` (exact CAN frame bits, :class:`CanFrame`, SocketCAN).

The module moved into the ``skinframes.canbus`` package; this one re-exports its names so that
scripts written against ``skinframes.canwire`` keep working. New code imports from
``skinframes.canbus`` (``from skinframes.canbus import frame_bits``).
"""

from skinframes.canbus.wire import (
    CAN_EFF_FLAG,
    CAN_ERR_FLAG,
    CAN_RTR_FLAG,
    EFF_FIXED_BITS,
    MAX_DATA_BYTES,
    MAX_DLC,
    MAX_EFF_ID,
    MAX_SFF_ID,
    SFF_FIXED_BITS,
    SOCKETCAN_MTU,
    CanFrame,
    crc15,
    frame_bits,
    frame_bits_batch,
    stuff_bits,
    unstuffed_bits,
    worst_case_bits,
)
from skinframes.canbus.wire import CAN_ERR_DLC as CAN_ERR_DLC
from skinframes.canbus.wire import CANFD_FDF as CANFD_FDF
from skinframes.canbus.wire import CRC15_POLY as CRC15_POLY
from skinframes.canbus.wire import CRC_BITS as CRC_BITS
from skinframes.canbus.wire import EFF_HEADER_BITS as EFF_HEADER_BITS
from skinframes.canbus.wire import INTERMISSION_BITS as INTERMISSION_BITS
from skinframes.canbus.wire import SFF_HEADER_BITS as SFF_HEADER_BITS
from skinframes.canbus.wire import SOCKETCAN_HEADER_BYTES as SOCKETCAN_HEADER_BYTES
from skinframes.canbus.wire import SOCKETCANFD_MTU as SOCKETCANFD_MTU
from skinframes.canbus.wire import STUFF_RUN as STUFF_RUN
from skinframes.canbus.wire import TRAILER_BITS as TRAILER_BITS

__all__ = [
    "CAN_EFF_FLAG",
    "CAN_ERR_FLAG",
    "CAN_RTR_FLAG",
    "EFF_FIXED_BITS",
    "MAX_DATA_BYTES",
    "MAX_DLC",
    "MAX_EFF_ID",
    "MAX_SFF_ID",
    "SFF_FIXED_BITS",
    "SOCKETCAN_MTU",
    "CanFrame",
    "crc15",
    "frame_bits",
    "frame_bits_batch",
    "stuff_bits",
    "unstuffed_bits",
    "worst_case_bits",
]
