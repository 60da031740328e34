"""skinframes.powerlink.cdc against the kit's shipped CDC and its openCONFIGURATOR text.

The kit's source archive holds openCONFIGURATOR's Demo_3CN output: ``mnobd.cdc`` (binary, 49
entries) and ``mnobd.txt``. The text is parsed here on its own (the README's format: hex count,
``index sub size value`` lines, a 0x1F22 line followed by its nested block) and compared with
what the reader makes of the binary. Expected values of :func:`skin_cdc` are computed by hand
from DS 301's mapping layout (6.4.9.2) and the kit's README.
"""

from __future__ import annotations

from typing import Any

import pytest
from epl_mn_util import shipped_files

from skinframes.errors import FieldRangeError, LengthMismatchError, TruncatedError
from skinframes.powerlink.cdc import (
    CdcEntry,
    SkinConfig,
    check_skin,
    decode_cdc,
    encode_cdc,
    skin_cdc,
    to_text,
)


@pytest.fixture(scope="module")
def shipped() -> dict[str, bytes]:
    """``mnobd.cdc`` and ``mnobd.txt`` from the kit's archive."""
    return shipped_files()


def parse_text(text: str) -> list[Any]:
    """mnobd.txt as nested lists: [index, sub, size, value] or [0x1F22, sub, size, [...]]."""
    tokens = [
        line.split()
        for line in text.splitlines()
        if line.strip() and not line.lstrip().startswith("//")
    ]
    rows = iter(tokens)

    def block() -> list[Any]:
        (count,) = next(rows)
        out: list[Any] = []
        for _ in range(int(count, 16)):
            row = next(rows)
            index, sub, size = (int(t, 16) for t in row[:3])
            if index == 0x1F22:
                assert len(row) == 3
                out.append([index, sub, size, block()])
            else:
                out.append([index, sub, size, int(row[3], 16)])
        return out

    result = block()
    assert next(rows, None) is None
    return result


def as_lists(entries: tuple[CdcEntry, ...]) -> list[Any]:
    return [
        [e.index, e.subindex, len(e.data), as_lists(e.nested) if e.index == 0x1F22 else e.value]
        for e in entries
    ]


def test_the_reader_reads_the_shipped_cdc_as_its_text_says(shipped: dict[str, bytes]) -> None:
    entries = decode_cdc(shipped["mnobd.cdc"])
    assert len(shipped["mnobd.cdc"]) == 951 and len(entries) == 49  # the kit's README
    assert as_lists(entries) == parse_text(shipped["mnobd.txt"].decode("ascii"))


def test_the_shipped_cdc_writes_back_byte_for_byte(shipped: dict[str, bytes]) -> None:
    entries = decode_cdc(shipped["mnobd.cdc"])
    assert encode_cdc(entries) == shipped["mnobd.cdc"]
    # the text form: openCONFIGURATOR's lines, its comments and blank lines aside
    ours = [ln for ln in to_text(entries).splitlines() if ln and not ln.startswith("//")]
    theirs = [
        ln.strip()
        for ln in shipped["mnobd.txt"].decode("ascii").splitlines()
        if ln.strip() and not ln.startswith("//")
    ]
    assert ours == theirs


@pytest.mark.parametrize(
    ("data", "error"),
    [
        (b"\x01\x00\x00", TruncatedError),
        (b"\x01\x00\x00\x00\x06\x10\x00\x04\x00\x00\x00\x50\xc3", TruncatedError),
        (b"\x00\x00\x00\x00\x00", LengthMismatchError),
        (b"\x02\x00\x00\x00\x06\x10\x00\x00\x00\x00\x00", TruncatedError),
    ],
)
def test_a_short_or_long_cdc_is_refused(data: bytes, error: type[Exception]) -> None:
    with pytest.raises(error):
        decode_cdc(data)


def test_the_skin_cdc_follows_demo_3cn(shipped: dict[str, bytes]) -> None:
    """For the demo's nodes the MN's objects are the demo's, in its order, plus the payload
    limits 0x1F8B/0x1F8D; each CN's block is the demo's plus the second TPDO entry."""
    demo = decode_cdc(shipped["mnobd.cdc"])
    ours = skin_cdc(SkinConfig((1, 32, 110), 24, 50_000, 200, 500))
    keys = [(e.index, e.subindex) for e in ours if e.index not in (0x1F8B, 0x1F8D)]
    assert keys == [(e.index, e.subindex) for e in demo]
    demo_cn = [(e.index, e.subindex) for e in demo[-4].nested]
    ours_cn = [(e.index, e.subindex) for e in ours[-4].nested]
    assert ours_cn == [*demo_cn[:12], (0x1A00, 2), *demo_cn[12:]]
    # with the demo's timing (50 ms, PRes timeout 200 us, async slot 500 us) every MN object
    # the demo sets holds the demo's bytes
    mine = [e for e in ours if e.index not in (0x1F8B, 0x1F8D, 0x1F22)]
    assert mine == [e for e in demo if e.index != 0x1F22]


def test_the_skin_cdc_values_by_hand() -> None:
    entries = skin_cdc(SkinConfig((5, 9), 192, 10_000, 2_000, 3_000))
    mn = {(e.index, e.subindex): e for e in entries if e.index not in (0x1F22, 0x1F81)}
    assert mn[(0x1006, 0)].data == (10_000).to_bytes(4, "little")
    assert mn[(0x1F92, 9)].value == 2_000_000  # ns
    assert mn[(0x1F8A, 2)].value == 3_000_000  # ns
    assert mn[(0x1F8D, 5)].data == (193).to_bytes(2, "little")  # 192 taxels + 0x6000/1
    assert mn[(0x1F8B, 5)].value == 36
    assert mn[(0x1801, 1)].value == 9  # the MN's second TPDO channel: node 9's PReq
    # MN RPDO 1 (node 9): 8 bits at offset 0 to 0xA4C0/2, as Demo_3CN's 0x000800000002A4C0
    assert mn[(0x1601, 1)].value == 0x000800000002A4C0
    f81 = [e for e in entries if e.index == 0x1F81]
    assert [e.value for e in f81] == [7, 7, 0x80000007, 0x80000007]
    (cn5, _cn9) = (e for e in entries if e.index == 0x1F22)
    assert cn5.subindex == 5
    # 15 entries: four of 1 byte (7 + 1 each), six of 4 (7 + 4), two of 2 (7 + 2), three of 8
    # (7 + 8), after the 4-byte count: 4 + 32 + 66 + 18 + 45 = 165
    assert len(cn5.data) == 165
    cn = {(e.index, e.subindex): e.value for e in cn5.nested}
    # DS 301 6.4.9.2: length (bits) << 48 | offset (bits) << 32 | sub << 16 | index;
    # 192 bytes = 1536 = 0x600 bits
    assert cn[(0x1A00, 1)] == 0x0600_0000_0001_6100
    assert cn[(0x1A00, 2)] == 0x0008_0600_0001_6000
    assert cn[(0x1600, 1)] == 0x0008_0000_0001_6200
    assert cn[(0x1F98, 5)] == 193 and cn[(0x1F98, 4)] == 36
    assert cn[(0x1A00, 0)] == 2 and cn[(0x1006, 0)] == 10_000


def test_what_the_stock_mn_cannot_run_is_refused() -> None:
    check_skin(list(range(1, 41)), 1489)
    with pytest.raises(FieldRangeError, match="40 RPDO"):
        check_skin(list(range(1, 42)), 8)
    with pytest.raises(FieldRangeError, match=r"1\.\.1489"):
        check_skin([1], 1490)
    with pytest.raises(FieldRangeError, match="twice"):
        check_skin([3, 3], 8)
    with pytest.raises(FieldRangeError):
        skin_cdc(SkinConfig((1,), 8, 10_000, 5_000_000, 100))  # 5e12 ns in a UNSIGNED32
