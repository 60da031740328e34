"""IEEE 802.1Q VLAN tags (C-tag, TPID 0x8100) and IEEE 802.1ad stacked tags (S-tag, TPID 0x88A8).

A tag sits between the source MAC and the EtherType (IEEE 802.1Q-2018 9.5, 9.6): a 16-bit tag
protocol identifier, then the tag control information PCP:3 | DEI:1 | VID:12, both big-endian. An
802.1ad frame carries an S-tag before the C-tag (IEEE 802.1Q-2018 6.9, "Q-in-Q"). Wireshark
dissects both TPIDs with its ``vlan`` dissector (``packet-vlan.c``: ``vlan.priority``,
``vlan.dei``, ``vlan.id``, ``vlan.etype``), and so does skinframes: a tagged EPL or EtherCAT frame
decodes to the same message as the untagged one, with the tags in
:attr:`skinframes.ethernet.EthernetFrame.tags`.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import TYPE_CHECKING, Final

import construct as cs

from skinframes.errors import FieldRangeError, TruncatedError

if TYPE_CHECKING:  # numpy is imported where an array is made: reading needs none
    import numpy as np
    import numpy.typing as npt

__all__ = [
    "MAX_TAGS",
    "TAG_BYTES",
    "TPIDS",
    "TPID_CTAG",
    "TPID_QINQ_OLD",
    "TPID_STAG",
    "VlanTag",
    "peel",
    "tag_frames",
    "tag_schema",
]

TAG_BYTES: Final = 4  # TPID + TCI, IEEE 802.1Q-2018 9.5
TPID_CTAG: Final = 0x8100  # customer VLAN tag, IEEE 802.1Q-2018 Table 9-1
TPID_STAG: Final = 0x88A8  # service VLAN tag (802.1ad), IEEE 802.1Q-2018 Table 9-1
TPID_QINQ_OLD: Final = 0x9100  # pre-802.1ad Q-in-Q, still dissected as VLAN by Wireshark
TPIDS: Final = frozenset({TPID_CTAG, TPID_STAG, TPID_QINQ_OLD})
MAX_TAGS: Final = 8  # more stacked tags than any network uses: the rest is kept as payload
_MAC_PAIR_BYTES: Final = 12

tag_schema = cs.Struct(
    "tpid" / cs.Int16ub,
    "tci"
    / cs.BitStruct(
        "pcp" / cs.BitsInteger(3),  # priority code point, 802.1Q-2018 9.6
        "dei" / cs.Flag,  # drop eligible indicator
        "vid" / cs.BitsInteger(12),  # VLAN identifier (0: priority tag only; 0xFFF reserved)
    ),
)

_TAG = struct.Struct(">HH")


@dataclass(frozen=True, slots=True)
class VlanTag:
    """One VLAN tag (IEEE 802.1Q-2018 9.5/9.6).

    Attributes:
        vid: VLAN identifier, 12 bits.
        pcp: priority code point, 3 bits.
        dei: drop eligible indicator.
        tpid: 0x8100 (C-tag), 0x88A8 (S-tag, 802.1ad) or 0x9100.
    """

    vid: int
    pcp: int = 0
    dei: bool = False
    tpid: int = TPID_CTAG

    def __post_init__(self) -> None:
        if not 0 <= self.vid <= 0xFFF:
            raise FieldRangeError(f"VLAN: VID {self.vid} does not fit 12 bits", field="vid")
        if not 0 <= self.pcp <= 7:
            raise FieldRangeError(f"VLAN: PCP {self.pcp} does not fit 3 bits", field="pcp")
        if self.tpid not in TPIDS:
            raise FieldRangeError(f"VLAN: TPID {self.tpid:#06x} is not a tag", field="tpid")

    @property
    def tci(self) -> int:
        """The 16-bit tag control information."""
        return self.pcp << 13 | int(self.dei) << 12 | self.vid

    def to_bytes(self) -> bytes:
        """TPID + TCI, big-endian (4 bytes)."""
        return _TAG.pack(self.tpid, self.tci)

    @classmethod
    def from_bytes(cls, data: bytes) -> VlanTag:
        """Decode 4 bytes.

        Raises:
            TruncatedError: fewer than 4 bytes.
            FieldRangeError: the TPID is no VLAN TPID.
        """
        if len(data) < TAG_BYTES:
            raise TruncatedError(f"VLAN: {len(data)} bytes, a tag needs {TAG_BYTES}")
        tpid, tci = _TAG.unpack_from(data)
        return cls(tci & 0xFFF, tci >> 13, bool(tci & 0x1000), tpid)


def peel(data: bytes) -> tuple[tuple[VlanTag, ...], int, int]:
    """The tags of an Ethernet frame, the EtherType after them, and where the payload starts.

    ``data`` starts with the destination MAC. An untagged frame gives ``((), ethertype, 14)``.
    A tag cut short by the end of the frame ends the peeling: its bytes stay payload.
    """
    tags: list[VlanTag] = []
    at = _MAC_PAIR_BYTES
    (ethertype,) = struct.unpack_from(">H", data, at)
    while ethertype in TPIDS and len(tags) < MAX_TAGS and len(data) >= at + TAG_BYTES + 2:
        tags.append(VlanTag.from_bytes(data[at : at + TAG_BYTES]))
        at += TAG_BYTES
        (ethertype,) = struct.unpack_from(">H", data, at)
    return tuple(tags), ethertype, at + 2


def tag_frames(
    frames: npt.NDArray[np.uint8], tags: tuple[VlanTag, ...], payload_bytes: int
) -> npt.NDArray[np.uint8]:
    """Rows of untagged frames as :class:`~skinframes.ethernet.EthernetFrame` encodes them with
    ``tags`` (batch fast path, proven equal in tests/skinframes/test_ethernet.py).

    Args:
        frames: (k, L) untagged frames: 14-byte header, ``payload_bytes`` of payload, zero
            padding to the 60-byte minimum.
        tags: the tags, outermost first, inserted after the source MAC.
        payload_bytes: the payload's length (the same in every row).

    Returns:
        (k, max(60, 14 + 4 x tags + payload_bytes)): the padding shrinks by what the tags add.
    """
    import numpy as np  # here, not at the top: reading captures needs no numpy

    frames = np.asarray(frames, dtype=np.uint8)
    if not tags:
        return frames
    k = frames.shape[0]
    head = _MAC_PAIR_BYTES
    extra = TAG_BYTES * len(tags)
    used = head + 2 + payload_bytes  # through the payload, untagged
    if frames.ndim != 2 or frames.shape[1] < used:
        raise FieldRangeError(f"VLAN batch: rows shorter than 14 + {payload_bytes} bytes")
    width = max(60, used + extra)  # IEEE 802.3 minimum, as ethernet.padding_for counts it
    out = np.zeros((k, width), dtype=np.uint8)
    out[:, :head] = frames[:, :head]
    out[:, head : head + extra] = np.frombuffer(b"".join(t.to_bytes() for t in tags), np.uint8)
    out[:, head + extra : used + extra] = frames[:, head:used]
    return out
