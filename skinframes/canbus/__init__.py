"""The iCub skin's legacy CAN frames: identifiers, head/tail payloads, reassembly, DBC.

The public model is frozen dataclasses: :class:`SkinFrame` (one CAN frame, half a triangle),
:class:`TriangleSample` (12 taxels + status of one triangle) and :class:`TimedSample`.
:class:`Reassembler` pairs heads and tails from a stream of :class:`CanFrame` and counts (never
raises on) what is not skin data.

Where things are (the names listed are importable from ``skinframes.canbus``, except ``log``'s):

- ``wire``: any classic CAN frame on the wire, skin or not: :class:`CanFrame`, its exact length
  (:func:`frame_bits`, :func:`worst_case_bits`, ...), CRC-15 and SocketCAN records.
- ``codec``: constants, identifiers, :class:`SkinFrame` and :class:`TriangleSample` with the
  head/tail layout (construct schemas of record and the ``bytes`` fast path); sources cited there.
- ``boards``: a board's sample as frames (:func:`encode_board`, :func:`decode_board`,
  :func:`idle_board`) and n samples at once with numpy (:func:`pack_frames`, :func:`unpack_frames`).
- ``reassembly``: :class:`Reassembler`, :func:`reassemble`, :class:`TimedSample` and the counts.
- ``dbc``: :func:`dbc_text`.
- ``log``: CAN log files (python-can's formats, SocketCAN pcap) read and written frame by frame;
  import it as ``skinframes.canbus.log`` (it is not re-exported here).

``skinframes.canwire`` and ``skinframes.cantrace`` are the old paths of ``wire`` and ``log``;
they still import.
"""

from skinframes.canbus.boards import (
    decode_board,
    encode_board,
    idle_board,
    pack_frames,
    unpack_frames,
)
from skinframes.canbus.codec import (
    BITRATE_BPS,
    DEFAULT_PERIOD_MS,
    FRAMES_PER_BOARD,
    HEAD_MARKER,
    LEGACY_SKIN_CLASS,
    MAX_BOARD,
    SKIN_CLASS,
    SKIN_DLC,
    TAIL_MARKER,
    Part,
    SensorError,
    SkinFrame,
    TriangleSample,
    board_ids,
    parse_skin_id,
    skin_id,
)
from skinframes.canbus.codec import ERROR_BITS as ERROR_BITS
from skinframes.canbus.codec import FRAMES_PER_TRIANGLE as FRAMES_PER_TRIANGLE
from skinframes.canbus.codec import HEAD_TAXELS as HEAD_TAXELS
from skinframes.canbus.codec import MAX_CLASS as MAX_CLASS
from skinframes.canbus.codec import MAX_ERROR as MAX_ERROR
from skinframes.canbus.codec import MAX_OUT_OF_RANGE as MAX_OUT_OF_RANGE
from skinframes.canbus.codec import OUT_OF_RANGE_BITS as OUT_OF_RANGE_BITS
from skinframes.canbus.codec import TAIL_TAXELS as TAIL_TAXELS
from skinframes.canbus.dbc import dbc_text
from skinframes.canbus.reassembly import (
    BoardCounts,
    BoardSample,
    FrameCounts,
    IdCount,
    Malformed,
    Reassembler,
    Reassembly,
    TimedSample,
    reassemble,
    sample_frames,
)
from skinframes.canbus.wire import (
    CAN_EFF_FLAG,
    CAN_ERR_FLAG,
    CAN_RTR_FLAG,
    SOCKETCAN_MTU,
    CanFrame,
    crc15,
    frame_bits,
    frame_bits_batch,
    stuff_bits,
    unstuffed_bits,
    worst_case_bits,
)

__all__ = [
    "BITRATE_BPS",
    "CAN_EFF_FLAG",
    "CAN_ERR_FLAG",
    "CAN_RTR_FLAG",
    "DEFAULT_PERIOD_MS",
    "FRAMES_PER_BOARD",
    "HEAD_MARKER",
    "LEGACY_SKIN_CLASS",
    "MAX_BOARD",
    "SKIN_CLASS",
    "SKIN_DLC",
    "SOCKETCAN_MTU",
    "TAIL_MARKER",
    "BoardCounts",
    "BoardSample",
    "CanFrame",
    "FrameCounts",
    "IdCount",
    "Malformed",
    "Part",
    "Reassembler",
    "Reassembly",
    "SensorError",
    "SkinFrame",
    "TimedSample",
    "TriangleSample",
    "board_ids",
    "crc15",
    "dbc_text",
    "decode_board",
    "encode_board",
    "frame_bits",
    "frame_bits_batch",
    "idle_board",
    "pack_frames",
    "parse_skin_id",
    "reassemble",
    "sample_frames",
    "skin_id",
    "stuff_bits",
    "unpack_frames",
    "unstuffed_bits",
    "worst_case_bits",
]
