"""pack_soc_frames: k SoC frames at once, byte-identical to ``frame(SoC(...)).to_bytes()``.

The hand-built vector follows DS 301 4.6.1.1.1 (SoC: MessageType 0x01, Destination 255 (broadcast),
Source 240 (MN), reserved, flags, reserved, NetTime seconds u32, nanoseconds u32, RelativeTime
u64, little endian) behind an Ethernet header to 01:11:1e:00:00:01 (C_DLL_MULTICAST_SOC) from
skinframes' MN address 02:00:00:00:0a:f0, EtherType 0x88AB, zero padding to 60 bytes.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from skinframes import decode_frame, powerlink
from skinframes.errors import FieldRangeError
from skinframes.powerlink import SoC

u32 = st.integers(0, 2**32 - 1)
u64 = st.integers(0, 2**64 - 1)


def test_pack_soc_frames_by_hand() -> None:
    out = powerlink.pack_soc_frames([0x01020304], [0x05060708], [0x1112131415161718])
    expected = bytes.fromhex(
        "01111e000001"  # destination: SoC multicast
        "02000000 0af0"  # source: node 240
        "88ab"  # EtherType EPL
        "01 ff f0 00 00 00"  # SoC, to 255, from 240, reserved, flags, reserved
        "04030201 08070605"  # NetTime seconds, nanoseconds
        "1817161514131211"  # RelativeTime
    )
    expected += bytes(60 - len(expected))
    assert out.dtype == np.uint8
    assert out.shape == (1, 60)
    assert out[0].tobytes() == expected


@given(st.lists(st.tuples(u32, u32, u64), max_size=8))
def test_pack_soc_frames_equals_per_frame_encoding(times: list[tuple[int, int, int]]) -> None:
    seconds = [t[0] for t in times]
    nanoseconds = [t[1] for t in times]
    relative = [t[2] for t in times]
    out = powerlink.pack_soc_frames(seconds, nanoseconds, relative)
    assert out.shape == (len(times), 60)
    for row, (s, ns, rel) in zip(out, times, strict=True):
        soc = SoC(net_time_s=s, net_time_ns=ns, relative_time_us=rel)
        assert row.tobytes() == powerlink.frame(soc).to_bytes()
        decoded = decode_frame(row.tobytes(), strict=True).payload
        assert decoded == soc


@given(st.lists(u32, min_size=1, max_size=6), u32, u64)
def test_pack_soc_frames_from_numpy_arrays_and_scalars(
    seconds: list[int], nanoseconds: int, relative: int
) -> None:
    out = powerlink.pack_soc_frames(
        np.array(seconds, dtype=np.uint32), nanoseconds, np.uint64(relative)
    )
    for row, s in zip(out, seconds, strict=True):
        soc = SoC(net_time_s=s, net_time_ns=nanoseconds, relative_time_us=relative)
        assert row.tobytes() == powerlink.frame(soc).to_bytes()


def test_pack_soc_frames_keeps_python_ints_exact() -> None:
    # np.asarray([1, 2**63]) is float64 (2**63 + 1 would round); the batch must not go through it
    out = powerlink.pack_soc_frames([0, 0], [0, 0], [1, 2**63 + 1])
    assert out[1, 28:36].tobytes() == bytes.fromhex("0100000000000080")
    assert out[0, 28:36].tobytes() == bytes.fromhex("0100000000000000")


@pytest.mark.parametrize(
    ("seconds", "nanoseconds", "relative"),
    [
        ([2**32], [0], [0]),
        ([-1], [0], [0]),
        ([0], [2**32], [0]),
        ([0], [0], [2**64]),
        ([0], [0], [-1]),
        ([0, 1], [0, 1, 2], [0]),  # lengths do not line up
        ([[0]], [0], [0]),  # not 1-D
    ],
)
def test_pack_soc_frames_out_of_range(
    seconds: list[int], nanoseconds: list[int], relative: list[int]
) -> None:
    with pytest.raises(FieldRangeError):
        powerlink.pack_soc_frames(seconds, nanoseconds, relative)


def test_pack_soc_frames_types_and_empty() -> None:
    with pytest.raises(TypeError):
        powerlink.pack_soc_frames([0.5], [0], [0])
    with pytest.raises(TypeError):
        powerlink.pack_soc_frames([0], ["1"], [0])
    assert powerlink.pack_soc_frames([], [], []).shape == (0, 60)
