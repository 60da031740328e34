"""Classic CAN frames on the wire: exact bit length, worst case, CRC-15, SocketCAN records.

Nothing here is specific to the skin (that is the rest of :mod:`skinframes.canbus`, which
re-exports these names; ``skinframes.canwire`` is this module's old path and still works).
Sources (see ../shared/reference/can.md, section 2):

- Frame format: ISO 11898-1 (Bosch CAN 2.0 part A and B). Destuffed fields of a data frame:
  SOF 1 | ID 11 | RTR 1 | IDE 1 | r0 1 | DLC 4 | DATA 8n | CRC 15 | CRC delimiter 1 | ACK slot 1 |
  ACK delimiter 1 | EOF 7, followed by the 3-bit intermission: 47 + 8n bits (2.0A). 2.0B replaces
  ID/RTR/IDE/r0 by base ID 11 | SRR | IDE | ID extension 18 | RTR | r1 | r0: 67 + 8n bits.
- Bit stuffing from SOF through the last CRC bit: after 5 equal bits the transmitter inserts their
  complement, which starts the next run (also after the last CRC bit). The CRC is CRC-15, poly
  0x4599, init 0, over SOF..data. Exact = fixed bits + stuff bits found on the real bits; this
  is what Vector's ``BitCount`` (ASC logs) reports and what can-utils ``canframelen.c``
  ``cfl_exact()`` computes. A remote frame sends no data field whatever its DLC; DLC 9..15
  carries 8 bytes but the raw DLC is in the stuffed stream.
- Worst case (Davis, Burns, Bril, Lukkien, Real-Time Systems 35:239-272, 2007, eq. 1):
  ``floor((g + 8n - 1) / 4)`` stuff bits over the g + 8n stuffable bits -> 55 + 10n (2.0A),
  80 + 10n (2.0B), intermission included; Linux ``include/linux/can/length.h`` agrees.
- SocketCAN records (LINKTYPE_CAN_SOCKETCAN = 227): Linux ``struct can_frame`` /
  ``struct canfd_frame`` (``include/uapi/linux/can.h``), the 32-bit CAN-id word big-endian in pcap
  files as Wireshark's ``packet-socketcan.c`` expects by default.
"""

from __future__ import annotations

import struct
from dataclasses import KW_ONLY, dataclass
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from skinframes.errors import FieldRangeError, FrameTooLargeError, InvalidFieldError, TruncatedError

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

# --- classic CAN frame format (ISO 11898-1; can.md 2) ---------------------------------------------
MAX_SFF_ID: Final = 0x7FF
MAX_EFF_ID: Final = 0x1FFFFFFF
MAX_DATA_BYTES: Final = 8
MAX_DLC: Final = 15  # DLC 9..15 still carries 8 bytes in classic CAN
SFF_HEADER_BITS: Final = 19  # SOF, ID 11, RTR, IDE, r0, DLC 4
EFF_HEADER_BITS: Final = 39  # SOF, base ID 11, SRR, IDE, ID extension 18, RTR, r1, r0, DLC 4
CRC_BITS: Final = 15
CRC15_POLY: Final = 0x4599  # x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1
TRAILER_BITS: Final = 1 + 1 + 1 + 7  # CRC delimiter, ACK slot, ACK delimiter, EOF (not stuffed)
INTERMISSION_BITS: Final = 3
SFF_FIXED_BITS: Final = SFF_HEADER_BITS + CRC_BITS + TRAILER_BITS + INTERMISSION_BITS  # 47
EFF_FIXED_BITS: Final = EFF_HEADER_BITS + CRC_BITS + TRAILER_BITS + INTERMISSION_BITS  # 67
STUFF_RUN: Final = 5  # after 5 equal bits a complement bit is inserted

# --- Linux SocketCAN (include/uapi/linux/can.h), LINKTYPE_CAN_SOCKETCAN records (can.md 5) ---------
CAN_EFF_FLAG: Final = 0x80000000
CAN_RTR_FLAG: Final = 0x40000000
CAN_ERR_FLAG: Final = 0x20000000
CANFD_FDF: Final = 0x04  # canfd_frame.flags: this is a CAN FD frame
# can_id (u32, big-endian in pcap files), len, pad (CAN FD: flags), res0, len8_dlc
SOCKETCAN_HEADER_BYTES: Final = 8
SOCKETCAN_MTU: Final = SOCKETCAN_HEADER_BYTES + MAX_DATA_BYTES  # 16, struct can_frame
SOCKETCANFD_MTU: Final = SOCKETCAN_HEADER_BYTES + 64  # 72, struct canfd_frame
CAN_ERR_DLC: Final = 8
_SOCKETCAN = struct.Struct(">IBBBB")


def check_range(name: str, value: int, high: int, low: int = 0) -> None:
    """Raise TypeError for a non-integer, :class:`FieldRangeError` outside ``low..high``.

    The one range check of ``skinframes.canbus`` (codec, reassembly and dbc use it too).
    """
    if not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an int, not {type(value).__name__}")
    if not low <= value <= high:
        raise FieldRangeError(f"{name}={value} is outside {low}..{high}", field=name)


# --- exact bits on the wire (can.md 2) -------------------------------------------------------------
def _crc_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << (CRC_BITS - 8)
        for _ in range(8):
            crc = (crc << 1) ^ CRC15_POLY if crc & 0x4000 else crc << 1
        table.append(crc & 0x7FFF)
    return tuple(table)


_CRC_TABLE: Final = _crc_table()


def crc15(bits: int, nbits: int) -> int:
    """CAN's CRC-15 (poly 0x4599, init 0, MSB first) of the ``nbits`` low bits of ``bits``."""
    data = bits.to_bytes((nbits + 7) // 8, "big")  # leading zero bits leave a zero-init CRC alone
    crc = 0
    for b in data:
        crc = ((crc << 8) & 0x7FFF) ^ _CRC_TABLE[((crc >> 7) ^ b) & 0xFF]
    return crc


def _run(state: int, value: int, width: int) -> tuple[int, int]:
    """Send ``width`` bits of ``value`` (MSB first) from ``state``: (new state, stuff bits).

    States: 0 = nothing sent yet, else ``1 + 4 * last_bit + run - 1`` with run 1..4 (a run of 5
    is broken at once by the stuff bit, the complement, which starts a new run of 1).
    """
    last, run = (0, 0) if state == 0 else ((state - 1) // 4, (state - 1) % 4 + 1)
    stuffed = 0
    for i in range(width - 1, -1, -1):
        bit = (value >> i) & 1
        if run and bit == last:
            run += 1
        else:
            last, run = bit, 1
        if run == STUFF_RUN:
            stuffed += 1
            last, run = 1 - last, 1
    return 1 + 4 * last + run - 1, stuffed


_STATES: Final = 9
# byte-wise automaton: index = state << 8 | byte
_NEXT: Final = tuple(_run(s, b, 8)[0] for s in range(_STATES) for b in range(256))
_COUNT: Final = tuple(_run(s, b, 8)[1] for s in range(_STATES) for b in range(256))
# the CRC's last 7 bits: index = state << 7 | bits
_NEXT7: Final = tuple(_run(s, b, 7)[0] for s in range(_STATES) for b in range(128))
_COUNT7: Final = tuple(_run(s, b, 7)[1] for s in range(_STATES) for b in range(128))
# the first byte holds 5 (2.0A) or 1 (2.0B) zero pad bits before SOF: skip them
_SFF_PAD: Final = 8 * 3 - SFF_HEADER_BITS
_EFF_PAD: Final = 8 * 5 - EFF_HEADER_BITS
_FIRST_SFF: Final = tuple(_run(0, b, 8 - _SFF_PAD) for b in range(256))
_FIRST_EFF: Final = tuple(_run(0, b, 8 - _EFF_PAD) for b in range(256))
# numpy copies for the batch path, next state and count packed as ``state << 4 | count``
_STEP_NP: Final = np.array([n << 4 | c for n, c in zip(_NEXT, _COUNT, strict=True)], np.int32)
_COUNT7_NP: Final = np.array(_COUNT7, dtype=np.int32)
_FIRST_SFF_NP: Final = np.array([n << 4 | c for n, c in _FIRST_SFF], dtype=np.int32)
_FIRST_EFF_NP: Final = np.array([n << 4 | c for n, c in _FIRST_EFF], dtype=np.int32)
_CRC_NP: Final = np.array(_CRC_TABLE, dtype=np.int32)


def _header(arbitration_id: int, extended: bool, dlc: int, remote: bool) -> bytes:
    """SOF..DLC (19 or 39 bits), right-aligned in 3 or 5 bytes after 5 or 1 zero pad bits."""
    rtr = 1 if remote else 0
    if extended:
        check_range("arbitration_id", arbitration_id, MAX_EFF_ID)
        base, ext = arbitration_id >> 18, arbitration_id & 0x3FFFF
        # SOF 0 | base 11 | SRR 1 | IDE 1 | extension 18 | RTR | r1 0 | r0 0 | DLC 4
        return (base << 27 | 1 << 26 | 1 << 25 | ext << 7 | rtr << 6 | dlc).to_bytes(5, "big")
    check_range("arbitration_id", arbitration_id, MAX_SFF_ID)
    # SOF 0 | ID 11 | RTR | IDE 0 | r0 0 | DLC 4
    return (arbitration_id << 7 | rtr << 6 | dlc).to_bytes(3, "big")


def _wire_data(data: bytes, dlc: int | None, remote: bool) -> tuple[bytes, int]:
    """(data bytes sent on the wire, DLC field) after checking that they agree."""
    n = len(data)
    if n > MAX_DATA_BYTES:
        raise FrameTooLargeError(f"classic CAN: {n} data bytes > 8 (CAN FD is not modelled)")
    if dlc is None:
        dlc = n
    check_range("dlc", dlc, MAX_DLC)
    if remote:
        return b"", dlc
    if n != min(dlc, MAX_DATA_BYTES):
        raise FieldRangeError(
            f"data frame with DLC {dlc} carries {min(dlc, 8)} bytes, got {n}", field="dlc"
        )
    return bytes(data), dlc


def _stuffed(body: bytes, extended: bool) -> int:
    """Stuff bits of header + data (``body``, byte-aligned after the pad) + their CRC, one pass.

    The CRC runs over the same bytes: zero pad bits do not change a zero-initialised CRC.
    """
    crc_table, nxt, cnt = _CRC_TABLE, _NEXT, _COUNT
    b = body[0]
    crc = crc_table[b]
    state, stuffed = (_FIRST_EFF if extended else _FIRST_SFF)[b]
    for b in body[1:]:
        crc = ((crc << 8) & 0x7FFF) ^ crc_table[(crc >> 7) ^ b]
        i = state << 8 | b
        stuffed += cnt[i]
        state = nxt[i]
    i = state << 8 | crc >> 7  # CRC bits 14..7
    return stuffed + cnt[i] + _COUNT7[nxt[i] << 7 | (crc & 0x7F)]  # then bits 6..0


def stuff_bits(
    arbitration_id: int,
    data: bytes,
    extended: bool = False,
    dlc: int | None = None,
    remote: bool = False,
) -> int:
    """Stuff bits the transmitter inserts between SOF and the end of the CRC sequence.

    Arguments as :func:`frame_bits`.
    """
    wire, dlc = _wire_data(data, dlc, remote)
    return _stuffed(_header(arbitration_id, extended, dlc, remote) + wire, extended)


def unstuffed_bits(data_bytes: int, extended: bool = False) -> int:
    """Bits of a frame without stuff bits: 47 + 8n (2.0A) or 67 + 8n (2.0B), intermission included.

    ``data_bytes`` is the number of bytes on the wire (0 for a remote frame).
    """
    check_range("data_bytes", data_bytes, MAX_DATA_BYTES)
    return (EFF_FIXED_BITS if extended else SFF_FIXED_BITS) + 8 * data_bytes


def frame_bits(
    arbitration_id: int,
    data: bytes,
    extended: bool = False,
    dlc: int | None = None,
    remote: bool = False,
) -> int:
    """Exact bits a classic CAN data or remote frame occupies on the bus, 3-bit intermission included.

    ``47 + 8n + S`` (2.0A) or ``67 + 8n + S`` (2.0B), where S is the number of stuff bits found on
    the real SOF..CRC bit sequence (CRC-15 computed); this is what Vector's ``BitCount`` reports.
    At 1 Mbit/s one bit is 1 us.

    Args:
        arbitration_id: 11-bit (or 29-bit with ``extended``) identifier.
        data: the data bytes (ignored for remote frames, which send none).
        extended: CAN 2.0B 29-bit identifier.
        dlc: the DLC field when it differs from ``len(data)``: 9..15 on a data frame (8 bytes
            sent), or the requested length of a remote frame. Default ``len(data)``.
        remote: a remote frame (RTR): no data field on the wire.

    Raises:
        FieldRangeError: identifier or DLC out of range, DLC disagrees with the data.
        FrameTooLargeError: more than 8 data bytes.
    """
    wire, dlc = _wire_data(data, dlc, remote)
    body = _header(arbitration_id, extended, dlc, remote) + wire
    base = EFF_FIXED_BITS if extended else SFF_FIXED_BITS
    return base + 8 * len(wire) + _stuffed(body, extended)


def worst_case_bits(data_bytes: int, extended: bool = False) -> int:
    """Upper bound of :func:`frame_bits`: 55 + 10n (2.0A) or 80 + 10n (2.0B) (Davis et al. 2007).

    ``data_bytes`` is the number of bytes on the wire (0 for a remote frame).
    """
    stuffable = unstuffed_bits(data_bytes, extended) - TRAILER_BITS - INTERMISSION_BITS
    return unstuffed_bits(data_bytes, extended) + (stuffable - 1) // 4


# --- fast path: numpy ----------------------------------------------------------------------------
def frame_bits_batch(
    arbitration_ids: npt.ArrayLike,
    data: npt.ArrayLike,
    *,
    dlc: npt.ArrayLike | None = None,
    extended: npt.ArrayLike = False,
    remote: npt.ArrayLike = False,
) -> npt.NDArray[np.int64]:
    """:func:`frame_bits` for many frames at once (vectorised; same results).

    Args:
        arbitration_ids: (n,) identifiers.
        data: (n, k) uint8 data bytes, k <= 8, zero-padded rows; a data frame uses its first
            ``min(dlc, 8)`` bytes (the rest is ignored), a remote frame none. A list of ``bytes``
            works too (then the default DLC is each one's length).
        dlc: (n,) DLC fields; default k for every frame.
        extended: bool or (n,) bools.
        remote: bool or (n,) bools.

    Raises:
        FieldRangeError: shapes disagree, or a value is out of range (checked before casting).
    """
    try:
        ids = np.asarray(arbitration_ids, dtype=np.int64).reshape(-1)
    except (OverflowError, ValueError) as exc:
        raise FieldRangeError(f"arbitration_ids: {exc}") from exc
    n = ids.shape[0]
    arr: npt.NDArray[Any]
    if isinstance(data, list | tuple) and all(isinstance(d, bytes | bytearray) for d in data):
        lengths = [len(d) for d in data]
        if max(lengths, default=0) > MAX_DATA_BYTES:
            raise FrameTooLargeError(f"classic CAN: {max(lengths)} data bytes > 8")
        arr = np.zeros((len(data), max(lengths, default=0)), dtype=np.uint8)
        for row, d in enumerate(data):
            arr[row, : len(d)] = np.frombuffer(bytes(d), dtype=np.uint8)
        if dlc is None:
            dlc = lengths
    else:
        arr = np.asarray(data)
        if not np.issubdtype(arr.dtype, np.integer):
            raise FieldRangeError(f"data: dtype {arr.dtype}, expected integer bytes")
    if arr.ndim != 2 or arr.shape[0] != n or arr.shape[1] > MAX_DATA_BYTES:
        raise FieldRangeError(f"data: shape {arr.shape}, expected ({n}, k<=8)")
    if arr.size and (arr.min() < 0 or arr.max() > 0xFF):
        raise FieldRangeError("data: bytes must be 0..255")
    mat = arr.astype(np.int32)
    try:
        dlcs = (
            np.full(n, mat.shape[1], dtype=np.int64)
            if dlc is None
            else np.broadcast_to(np.asarray(dlc, dtype=np.int64), (n,))
        )
        ext = np.broadcast_to(np.asarray(extended, dtype=bool), (n,))
        rtr = np.broadcast_to(np.asarray(remote, dtype=bool), (n,))
    except (OverflowError, ValueError) as exc:
        raise FieldRangeError(f"dlc/extended/remote: {exc} (need {n} values)") from exc
    if n and (dlcs.min() < 0 or dlcs.max() > MAX_DLC):
        raise FieldRangeError("dlc: values must be 0..15")
    if n and (ids.min() < 0 or np.any(ids > np.where(ext, MAX_EFF_ID, MAX_SFF_ID))):
        raise FieldRangeError("arbitration_ids: out of range for 11/29-bit identifiers")
    wire = np.where(rtr, 0, np.minimum(dlcs, MAX_DATA_BYTES))
    if n and wire.max() > mat.shape[1]:
        raise FieldRangeError(f"data: {mat.shape[1]} columns, a DLC needs {wire.max()}")
    out = np.empty(n, dtype=np.int64)
    for is_ext in (False, True):
        for m in range(MAX_DATA_BYTES + 1):
            sel = np.flatnonzero((ext == is_ext) & (wire == m))
            if sel.size:
                out[sel] = _bits_group(ids[sel], dlcs[sel], rtr[sel], mat[sel, :m], is_ext)
    return out


def _bits_group(
    ids: npt.NDArray[np.int64],
    dlc: npt.NDArray[np.int64],
    rtr: npt.NDArray[np.bool_],
    data: npt.NDArray[np.int32],
    extended: bool,
) -> npt.NDArray[np.int64]:
    """Frames of one kind and one wire length m: :func:`_stuffed` run on columns of bytes."""
    m = data.shape[1]
    r = rtr.astype(np.int64)
    if extended:
        hdr = (ids >> 18) << 27 | 3 << 25 | (ids & 0x3FFFF) << 7 | r << 6 | dlc
        hbytes, first, fixed = 5, _FIRST_EFF_NP, EFF_FIXED_BITS
    else:
        hdr = ids << 7 | r << 6 | dlc
        hbytes, first, fixed = 3, _FIRST_SFF_NP, SFF_FIXED_BITS
    columns = [((hdr >> (8 * (hbytes - 1 - k))) & 0xFF).astype(np.int32) for k in range(hbytes)]
    columns += [data[:, k] for k in range(m)]
    crc = _CRC_NP[columns[0]]
    packed = first[columns[0]]  # next state << 4 | stuff bits
    stuffed = packed & 0xF
    state = packed >> 4
    for col in columns[1:]:
        crc = ((crc << 8) & 0x7FFF) ^ _CRC_NP[(crc >> 7) ^ col]
        packed = _STEP_NP[state << 8 | col]
        stuffed += packed & 0xF
        state = packed >> 4
    packed = _STEP_NP[state << 8 | crc >> 7]
    stuffed += (packed & 0xF) + _COUNT7_NP[(packed >> 4) << 7 | (crc & 0x7F)]
    bits: npt.NDArray[np.int64] = stuffed.astype(np.int64) + (fixed + 8 * m)
    return bits


@dataclass(frozen=True, slots=True)
class CanFrame:
    """One classic CAN frame as a trace records it (any identifier, not only skin data).

    Attributes:
        arbitration_id: 11-bit (``extended=False``) or 29-bit identifier; for an error frame
            the SocketCAN error-class bits (0 when the trace has none, as in python-can's).
        data: the data bytes (empty for remote frames; up to 64 for CAN FD frames; the
            SocketCAN error details for an error frame).
        time_ns: timestamp in nanoseconds, as the trace gives it.
        extended: 29-bit identifier (CAN 2.0B).
        remote: remote transmission request (no data on the wire; ``dlc`` gives the DLC field).
        error: an error frame (as loggers report one; no identifier, no bit length).
        fd: a CAN FD frame (not skin data; no bit length here).
        dlc: the raw 4-bit DLC field when it differs from ``len(data)``: remote frames and
            DLC 9..15 (which carries 8 bytes in classic CAN). ``None`` = ``len(data)``.
        channel: the logger's channel, when the trace has one.
    """

    arbitration_id: int
    data: bytes = b""
    _: KW_ONLY
    time_ns: int = 0
    extended: bool = False
    remote: bool = False
    error: bool = False
    fd: bool = False
    dlc: int | None = None
    channel: int | str | None = None

    @property
    def dlc_field(self) -> int:
        """The DLC as sent (``dlc`` or ``len(data)``)."""
        return len(self.data) if self.dlc is None else self.dlc

    def bits(self) -> int:
        """Bits on the wire (:func:`frame_bits`, stuffing and intermission included).

        Raises:
            FieldRangeError: an error frame or a CAN FD frame (not modelled), or bad fields.
        """
        if self.error or self.fd:
            kind = "error frame" if self.error else "CAN FD frame"
            raise FieldRangeError(f"{kind}: no exact bit length (classic data/remote frames only)")
        return frame_bits(self.arbitration_id, self.data, self.extended, self.dlc, self.remote)

    def to_socketcan(self) -> bytes:
        """The LINKTYPE_CAN_SOCKETCAN record: Linux ``struct can_frame`` (16 bytes) or
        ``struct canfd_frame`` (72 bytes), the CAN-id word big-endian as pcap requires.

        Error frames are written as ``CAN_ERR_FLAG | arbitration_id`` (the error class) with
        ``len`` 8 and ``data`` zero-padded (python-can traces carry neither: all zero).

        Raises:
            FieldRangeError: identifier or DLC out of range, more data than the frame type holds.
        """
        if self.error:
            check_range("arbitration_id", self.arbitration_id, MAX_EFF_ID)  # error class bits
            if len(self.data) > CAN_ERR_DLC:
                raise FrameTooLargeError(f"error frame: {len(self.data)} data bytes > 8")
            header = _SOCKETCAN.pack(CAN_ERR_FLAG | self.arbitration_id, CAN_ERR_DLC, 0, 0, 0)
            return header + self.data.ljust(CAN_ERR_DLC, b"\0")
        limit = MAX_SFF_ID if not self.extended else MAX_EFF_ID
        check_range("arbitration_id", self.arbitration_id, limit)
        can_id = self.arbitration_id | (CAN_EFF_FLAG if self.extended else 0)
        if self.fd:
            if len(self.data) > 64:
                raise FrameTooLargeError(f"CAN FD frame: {len(self.data)} data bytes > 64")
            return _SOCKETCAN.pack(can_id, len(self.data), CANFD_FDF, 0, 0) + self.data.ljust(
                64, b"\0"
            )
        dlc = self.dlc_field
        check_range("dlc", dlc, MAX_DLC)
        if self.remote:
            can_id |= CAN_RTR_FLAG
            length, payload = min(dlc, MAX_DATA_BYTES), b""
        else:
            if len(self.data) != min(dlc, MAX_DATA_BYTES):
                raise FieldRangeError(
                    f"CAN frame: {len(self.data)} data bytes with DLC {dlc}", field="dlc"
                )
            length, payload = len(self.data), self.data
        len8_dlc = dlc if dlc > MAX_DATA_BYTES else 0
        return _SOCKETCAN.pack(can_id, length, 0, 0, len8_dlc) + payload.ljust(8, b"\0")

    @classmethod
    def from_socketcan(cls, buf: bytes, time_ns: int = 0) -> CanFrame:
        """Decode a LINKTYPE_CAN_SOCKETCAN record (classic or FD, as Wireshark does).

        Raises:
            TruncatedError: fewer than 8 header bytes, or fewer data bytes than ``len`` says.
            InvalidFieldError: ``len`` larger than the frame type allows.
        """
        if len(buf) < SOCKETCAN_HEADER_BYTES:
            raise TruncatedError(
                f"SocketCAN record: {len(buf)} bytes, the header needs 8", offset=len(buf)
            )
        can_id, length, flags, _res0, len8_dlc = _SOCKETCAN.unpack_from(buf)
        fd = bool(flags & CANFD_FDF) or len(buf) == SOCKETCANFD_MTU
        extended = bool(can_id & CAN_EFF_FLAG)
        ident = can_id & (MAX_EFF_ID if extended else MAX_SFF_ID)
        if can_id & CAN_ERR_FLAG:  # error class in the id bits, details in the data
            data = buf[SOCKETCAN_HEADER_BYTES : SOCKETCAN_HEADER_BYTES + min(length, 8)]
            return cls(can_id & MAX_EFF_ID, bytes(data), time_ns=time_ns, error=True)
        if length > (64 if fd else MAX_DATA_BYTES):
            raise InvalidFieldError(f"SocketCAN record: len {length} > 8", field="len", offset=4)
        remote = bool(can_id & CAN_RTR_FLAG) and not fd
        dlc = None
        if not fd and length == MAX_DATA_BYTES and MAX_DATA_BYTES < len8_dlc <= MAX_DLC:
            dlc = len8_dlc
        if remote:
            return cls(
                ident, b"", time_ns=time_ns, extended=extended, remote=True, dlc=dlc or length
            )
        end = SOCKETCAN_HEADER_BYTES + length
        if len(buf) < end:
            raise TruncatedError(
                f"SocketCAN record: {len(buf)} bytes, len {length} needs {end}", offset=len(buf)
            )
        return cls(
            ident,
            bytes(buf[SOCKETCAN_HEADER_BYTES:end]),
            time_ns=time_ns,
            extended=extended,
            fd=fd,
            dlc=dlc,
        )
