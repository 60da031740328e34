"""The struct fast paths of every EPL message equal the construct schemas of record.

Random valid messages (hypothesis) and every EPL frame of the real captures and pcaps/ are
decoded both ways: by the message classes (struct) and by ``schema.parse`` (construct).
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import construct as cs
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from skinframes import ethernet, powerlink
from skinframes.errors import DecodeError, TruncatedError
from skinframes.pcap import read_capture
from skinframes.powerlink import messages

ROOT = Path(__file__).resolve().parent.parent.parent
SCHEMAS: dict[int, Any] = {
    powerlink.MessageType.SOC: powerlink.soc_schema,
    powerlink.MessageType.PREQ: powerlink.preq_schema,
    powerlink.MessageType.PRES: powerlink.pres_schema,
    powerlink.MessageType.SOA: powerlink.soa_schema,
    # the ASnd header (DS 301 4.6.1.1.6): common header + ServiceID; the services follow
    powerlink.MessageType.ASND: cs.Struct(
        "message_type" / cs.Int8ul, "dest" / cs.Int8ul, "src" / cs.Int8ul,
        "service_id" / cs.Int8ul,
    ),
}  # fmt: skip
CLASSES: dict[int, Any] = {
    powerlink.MessageType.SOC: messages.SoC,
    powerlink.MessageType.PREQ: messages.PReq,
    powerlink.MessageType.PRES: messages.PRes,
    powerlink.MessageType.SOA: messages.SoA,
    powerlink.MessageType.ASND: messages.ASnd,
}


def assert_equal_to_schema(buf: bytes) -> None:
    """The fast decode of ``buf`` has every field ``schema.parse`` gives, and the same length."""
    mtype = buf[0]
    if mtype == powerlink.MessageType.ASND:  # the header; the service has its own schemas
        try:
            fast, used, _ = powerlink.decode(buf, strict=False)
        except DecodeError:
            assume(False)
    else:
        fast, used = CLASSES[mtype]._decode(buf, False, [])
    parsed = SCHEMAS[mtype].parse(buf)
    for name, value in parsed.items():
        if name.startswith("_") or name == "message_type":
            continue
        ours = getattr(fast, name)
        assert ours == value, f"{type(fast).__name__}.{name}: struct {ours!r}, construct {value!r}"
    if mtype == powerlink.MessageType.ASND:
        return
    assert used == len(SCHEMAS[mtype].build(parsed))


byte = st.integers(0, 0xFF)


@given(st.binary(min_size=21, max_size=21), st.binary(max_size=40))
def test_soc(body: bytes, padding: bytes) -> None:
    assert_equal_to_schema(bytes([powerlink.MessageType.SOC]) + body + padding)


@given(
    st.sampled_from([powerlink.MessageType.PREQ, powerlink.MessageType.PRES]),
    st.binary(min_size=7, max_size=7),
    st.binary(max_size=1490),
    st.binary(max_size=40),
)
def test_preq_and_pres(mtype: int, head: bytes, payload: bytes, padding: bytes) -> None:
    size = struct.pack("<H", len(payload))
    assert_equal_to_schema(bytes([mtype]) + head + size + payload + padding)


@given(
    st.binary(min_size=5, max_size=5),
    st.one_of(byte, st.just(powerlink.RequestedService.SYNC_REQUEST)),
    st.binary(min_size=3, max_size=3),
    st.binary(min_size=30, max_size=30),
    st.binary(max_size=40),
)
def test_soa(head: bytes, service: int, tail: bytes, sync: bytes, padding: bytes) -> None:
    body = bytes([powerlink.MessageType.SOA]) + head + bytes([service]) + tail
    if service == powerlink.RequestedService.SYNC_REQUEST:
        body += sync
    assert_equal_to_schema(body + padding)


@given(
    st.binary(min_size=2, max_size=2),
    st.sampled_from([*powerlink.ServiceId, 0x55]),
    st.binary(max_size=60),
)
def test_asnd_header(head: bytes, service: int, body: bytes) -> None:
    assert_equal_to_schema(bytes([powerlink.MessageType.ASND]) + head + bytes([service]) + body)


def test_a_truncated_sync_request_is_truncated() -> None:
    soa = bytes([powerlink.MessageType.SOA, 255, 240, 0, 0, 0, 6, 1, 0x20, 0]) + bytes(29)
    with pytest.raises(cs.StreamError):
        powerlink.soa_schema.parse(soa)
    with pytest.raises(TruncatedError):
        powerlink.decode(soa, strict=False)


def epl_messages(paths: list[Path]) -> list[bytes]:
    out = []
    for path in paths:
        for rec in read_capture(path):
            if len(rec.data) > 15 and rec.data[12:14] == b"\x88\xab" and rec.data[14] in CLASSES:
                out.append(rec.data[ethernet.HEADER_BYTES :])
    return out


def test_every_epl_message_of_the_golden_pcaps() -> None:
    found = epl_messages(sorted((ROOT / "pcaps").glob("epl_*.pcap")))
    assert {m[0] for m in found} == set(CLASSES)
    for buf in found:
        assert_equal_to_schema(buf)


def test_every_epl_message_of_the_real_captures(shared_captures: Path) -> None:
    found = epl_messages(sorted(shared_captures.glob("epl-*")))
    assert len(found) > 1000
    for buf in found:
        assert_equal_to_schema(buf)
