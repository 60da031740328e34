"""Many PRes frames at once with numpy (the emulator's and the benchmarks' fast path).

:func:`pack_pres_frames` copies one frame that :class:`~skinframes.powerlink.PRes` and
:func:`~skinframes.powerlink.frame` encode, and writes into each copy only what differs: the
source node id (in the source MAC and in the EPL header) and the payload.
:func:`unpack_pres_frames` reads those columns back; :func:`pack_soc_frames` does the same
for SoCs and their time fields. Tests prove both equal to the per-frame
codec with hypothesis.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

from skinframes import ethernet
from skinframes.errors import FieldRangeError, InvalidFieldError, TruncatedError
from skinframes.powerlink.enums import MessageType, NmtState, PResFlag
from skinframes.powerlink.frames import frame
from skinframes.powerlink.messages import PRes, SoC, check_pdo_size
from skinframes.powerlink.schemas import (
    PDO_HEADER_BYTES,
    PDO_SIZE_OFFSET,
    SOC_NET_TIME_OFFSET,
    SRC_OFFSET,
)

if TYPE_CHECKING:  # numpy is imported where an array is made: reading needs none
    import numpy as np
    import numpy.typing as npt

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
    import numpy as np  # here, not at the top: reading captures needs no numpy

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
    import numpy as np  # here, not at the top: reading captures needs no numpy

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


def pack_soc_frames(
    net_time_s: npt.ArrayLike, net_time_ns: npt.ArrayLike, relative_time_us: npt.ArrayLike
) -> npt.NDArray[np.uint8]:
    """Build k complete SoC Ethernet frames at once (batch fast path, DS 301 4.6.1.1.1).

    Args:
        net_time_s: k NetTime seconds (u32); a scalar applies to every frame.
        net_time_ns: k NetTime nanoseconds (u32).
        relative_time_us: k RelativeTime values, microseconds (u64).

    Returns:
        uint8 array of shape (k, 60): each row a frame as ``frame(SoC(net_time_s=...,
        net_time_ns=..., relative_time_us=...)).to_bytes()`` encodes it (destination
        01:11:1e:00:00:01, source ``node_mac(240)``, dest 255, src 240, flags 0, zero padding):
        one frame encoded by :class:`SoC`, its time fields written per row.

    Raises:
        FieldRangeError: a value does not fit its field, or the lengths disagree.
    """
    import numpy as np  # here, not at the top: reading captures needs no numpy

    fields = [
        _unsigned("net_time_s", net_time_s, 32),
        _unsigned("net_time_ns", net_time_ns, 32),
        _unsigned("relative_time_us", relative_time_us, 64),
    ]
    try:
        seconds, nanoseconds, relative = np.broadcast_arrays(*fields)
    except ValueError as exc:
        sizes = ", ".join(str(f.size) for f in fields)
        raise FieldRangeError(f"EPL SoC batch: {sizes} values do not line up") from exc
    head = ethernet.HEADER_BYTES + SOC_NET_TIME_OFFSET
    template = np.frombuffer(frame(SoC()).to_bytes(), dtype=np.uint8)  # the one SoC encoder
    length = len(template)
    k = seconds.shape[0]
    out = np.empty((k, length), dtype=np.uint8)
    out[:] = template
    # NetTime seconds, NetTime nanoseconds, RelativeTime (soc_schema): 4 + 4 + 8 bytes
    out[:, head : head + 4] = seconds.astype("<u4").view(np.uint8).reshape(k, 4)
    out[:, head + 4 : head + 8] = nanoseconds.astype("<u4").view(np.uint8).reshape(k, 4)
    out[:, head + 8 : head + 16] = relative.astype("<u8").view(np.uint8).reshape(k, 8)
    return out


def _unsigned(name: str, values: npt.ArrayLike, bits: int) -> npt.NDArray[np.uint64]:
    """``values`` as a 1-D uint64 array, each checked to fit ``bits`` (numpy would wrap)."""
    import numpy as np  # here, not at the top: reading captures needs no numpy

    # Python ints stay Python ints: np.asarray([0, 2**63]) would round them through float64
    numeric = isinstance(values, np.ndarray | np.generic)
    arr = np.atleast_1d(values if numeric else np.asarray(values, dtype=object))
    if arr.ndim != 1:
        raise FieldRangeError(f"EPL SoC batch: {name} must be 1-D, not {arr.shape}", field=name)
    if arr.size == 0:
        return np.zeros(0, dtype=np.uint64)
    if arr.dtype == object:
        items = arr.tolist()
        if not all(isinstance(v, int | np.integer) and not isinstance(v, bool) for v in items):
            raise TypeError(f"{name} must be integers")
        low, high = int(min(items)), int(max(items))
    elif arr.dtype.kind in "iu":
        low, high = int(arr.min()), int(arr.max())
    else:
        raise TypeError(f"{name} must be integers, not {arr.dtype}")
    if low < 0 or high >= 1 << bits:
        raise FieldRangeError(
            f"EPL SoC batch: {name} values must be 0..2**{bits}-1, found {low}..{high}",
            field=name,
        )
    if arr.dtype == object:
        return np.array([int(v) for v in arr.tolist()], dtype=np.uint64)
    return arr.astype(np.uint64)
