"""Many PRes frames at once with numpy (the emulator's and the benchmarks' fast path).

:func:`pack_pres_frames` copies one frame that :class:`~skinframes.powerlink.PRes` and
:func:`~skinframes.powerlink.frame` encode, and writes into each copy only what differs: the
source node id (in the source MAC and in the EPL header) and the payload.
:func:`unpack_pres_frames` reads those columns back. Tests prove both equal to the per-frame
codec with hypothesis.
"""

from __future__ import annotations

from typing import Final

import numpy as np
import numpy.typing as npt

from skinframes import ethernet
from skinframes.errors import FieldRangeError, InvalidFieldError, TruncatedError
from skinframes.powerlink.enums import MessageType, NmtState, PResFlag
from skinframes.powerlink.frames import frame
from skinframes.powerlink.messages import PRes, check_pdo_size
from skinframes.powerlink.schemas import PDO_HEADER_BYTES, PDO_SIZE_OFFSET, SRC_OFFSET

# Columns of a PRes frame (Ethernet header, then the EPL bytes)
_EPL: Final = ethernet.HEADER_BYTES  # 14: the EPL message starts after the EtherType
_SRC_MAC_NODE: Final = 2 * ethernet.MAC_BYTES - 1  # 11: node_mac's last octet, the node id
_SRC: Final = _EPL + SRC_OFFSET  # 16
_SIZE: Final = _EPL + PDO_SIZE_OFFSET  # 22, 23: Size, little-endian
_PAYLOAD: Final = _EPL + PDO_HEADER_BYTES  # 24


def pack_pres_frames(
    payloads: npt.NDArray[np.uint8],
    src_nodes: npt.ArrayLike,
    nmt_status: int = NmtState.OPERATIONAL,
    flags1: int = PResFlag.RD,
) -> npt.NDArray[np.uint8]:
    """Build n complete PRes Ethernet frames at once (batch fast path).

    Args:
        payloads: uint8 array of shape (n, B), B <= 1490: the PDO of each frame.
        src_nodes: n source node ids (1..239).
        nmt_status: NMTStatus byte of every frame.
        flags1: flags byte of every frame.

    Returns:
        uint8 array of shape (n, max(14 + 10 + B, 60)): each row a frame as ``frame(PRes(...))``
        encodes it (destination 01:11:1e:00:00:02, source ``node_mac(src)``, zero padding).
    """
    payloads = np.asarray(payloads)
    if payloads.dtype != np.uint8 or payloads.ndim != 2:
        raise TypeError("payloads must be a 2-D uint8 array")
    n, size = payloads.shape
    check_pdo_size(size)
    src = np.asarray(src_nodes, dtype=np.int64).reshape(-1)
    if src.shape != (n,):
        raise FieldRangeError(f"EPL PRes batch: {src.shape[0]} source nodes for {n} payloads")
    if n and (src.min() < 0 or src.max() > 0xFF):
        raise FieldRangeError("EPL PRes batch: source node ids must fit 8 bits", field="src")
    template = frame(PRes(0, bytes(size), nmt_status=nmt_status, flags1=flags1)).to_bytes()
    out = np.empty((n, len(template)), dtype=np.uint8)
    out[:] = np.frombuffer(template, dtype=np.uint8)
    out[:, _SRC_MAC_NODE] = src
    out[:, _SRC] = src
    out[:, _PAYLOAD : _PAYLOAD + size] = payloads
    return out


def unpack_pres_frames(
    frames: npt.NDArray[np.uint8],
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]]:
    """Decode n equal-length PRes frames at once (batch fast path).

    Args:
        frames: uint8 array of shape (n, L), each row a PRes Ethernet frame with the same Size.

    Returns:
        (source node ids, payloads of shape (n, Size)); both are views into ``frames``.

    Raises:
        InvalidFieldError: a row is not a PRes, or the rows disagree on Size.
    """
    frames = np.asarray(frames, dtype=np.uint8)
    if frames.ndim != 2 or frames.shape[1] < _PAYLOAD:
        raise TruncatedError("EPL PRes batch: rows shorter than the 24-byte PRes header")
    ethertype = (frames[:, _EPL - 2].astype(np.int64) << 8) | frames[:, _EPL - 1]
    ethertype_ok = ethertype == ethernet.ETHERTYPE_EPL
    mtype_ok = (frames[:, _EPL] & 0x7F) == MessageType.PRES
    if not bool(np.all(ethertype_ok & mtype_ok)):
        raise InvalidFieldError(
            "EPL PRes batch: a row is not an EPL PRes frame", field="message_type"
        )
    sizes = frames[:, _SIZE].astype(np.int64) | (frames[:, _SIZE + 1].astype(np.int64) << 8)
    size = int(sizes[0]) if len(sizes) else 0
    if not bool(np.all(sizes == size)):
        raise InvalidFieldError("EPL PRes batch: rows disagree on the Size field", field="size")
    if _PAYLOAD + size > frames.shape[1]:
        raise TruncatedError(f"EPL PRes batch: Size {size} runs past the frame", field="size")
    return frames[:, _SRC], frames[:, _PAYLOAD : _PAYLOAD + size]
