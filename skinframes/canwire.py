"""Old path of :mod:`skinframes.canbus.wire` (exact CAN frame bits, :class:`CanFrame`, SocketCAN).

The module moved into the ``skinframes.canbus`` package; this one re-exports its names (its
``__all__`` and its public constants) so that scripts written against ``skinframes.canwire`` keep
working. New code imports from ``skinframes.canbus`` (``from skinframes.canbus import frame_bits``).
"""

from skinframes.canbus import wire as _new
from skinframes.canbus.wire import CAN_EFF_FLAG as CAN_EFF_FLAG
from skinframes.canbus.wire import CAN_ERR_DLC as CAN_ERR_DLC
from skinframes.canbus.wire import CAN_ERR_FLAG as CAN_ERR_FLAG
from skinframes.canbus.wire import CAN_RTR_FLAG as CAN_RTR_FLAG
from skinframes.canbus.wire import CANFD_FDF as CANFD_FDF
from skinframes.canbus.wire import CRC15_POLY as CRC15_POLY
from skinframes.canbus.wire import CRC_BITS as CRC_BITS
from skinframes.canbus.wire import EFF_FIXED_BITS as EFF_FIXED_BITS
from skinframes.canbus.wire import EFF_HEADER_BITS as EFF_HEADER_BITS
from skinframes.canbus.wire import INTERMISSION_BITS as INTERMISSION_BITS
from skinframes.canbus.wire import MAX_DATA_BYTES as MAX_DATA_BYTES
from skinframes.canbus.wire import MAX_DLC as MAX_DLC
from skinframes.canbus.wire import MAX_EFF_ID as MAX_EFF_ID
from skinframes.canbus.wire import MAX_SFF_ID as MAX_SFF_ID
from skinframes.canbus.wire import SFF_FIXED_BITS as SFF_FIXED_BITS
from skinframes.canbus.wire import SFF_HEADER_BITS as SFF_HEADER_BITS
from skinframes.canbus.wire import SOCKETCAN_HEADER_BYTES as SOCKETCAN_HEADER_BYTES
from skinframes.canbus.wire import SOCKETCAN_MTU as SOCKETCAN_MTU
from skinframes.canbus.wire import SOCKETCANFD_MTU as SOCKETCANFD_MTU
from skinframes.canbus.wire import STUFF_RUN as STUFF_RUN
from skinframes.canbus.wire import TRAILER_BITS as TRAILER_BITS
from skinframes.canbus.wire import CanFrame as CanFrame
from skinframes.canbus.wire import crc15 as crc15
from skinframes.canbus.wire import frame_bits as frame_bits
from skinframes.canbus.wire import frame_bits_batch as frame_bits_batch
from skinframes.canbus.wire import stuff_bits as stuff_bits
from skinframes.canbus.wire import unstuffed_bits as unstuffed_bits
from skinframes.canbus.wire import worst_case_bits as worst_case_bits

__all__ = list(_new.__all__)  # what `import *` gave before, from the one list
