"""Volume fuzzing: 10^6 generated inputs per decoder and reader under CI=true (3,000 otherwise).

Seeded mutations of real frames (the golden captures), frames with a valid header and a random
tail, and plain random bytes. Every decoder may only raise our DecodeError subclasses; capture
mode must give back every byte. Complements the hypothesis properties in test_fuzz.py with a count
hypothesis cannot reach in CI time.
"""

from __future__ import annotations

import gzip
import os
import random
import zlib
from collections.abc import Callable, Iterator

import pytest

from skinframes import canbus, decode_frame, ethercat, golden, powerlink, taxel
from skinframes.errors import DecodeError
from skinframes.ethernet import EthernetFrame
from skinframes.pcap import MarkedRecord, parse_capture, pcap_bytes, pcapng_bytes

COUNT = 1_000_000 if os.environ.get("CI", "").lower() == "true" else 3_000
SEEDS = [f for name in golden.SCENARIOS for _, f in golden.build(name)]


def inputs(seed: int, count: int = COUNT) -> Iterator[bytes]:
    rng = random.Random(seed)
    for i in range(count):
        kind = i % 3
        if kind == 0:
            yield rng.randbytes(rng.randrange(0, 120))
        elif kind == 1:
            buf = bytearray(rng.choice(SEEDS))
            for _ in range(rng.randrange(1, 4)):
                op = rng.randrange(3)
                at = rng.randrange(len(buf)) if buf else 0
                if op == 0 and buf:
                    buf[at] ^= 1 << rng.randrange(8)
                elif op == 1:
                    del buf[at:]
                else:
                    buf[at:at] = rng.randbytes(rng.randrange(1, 8))
            yield bytes(buf)
        else:
            head = rng.choice(SEEDS)[: 14 + rng.randrange(0, 12)]
            yield head + rng.randbytes(rng.randrange(0, 80))


def _epl(b: bytes) -> object:
    return powerlink.decode(b[14:], strict=bool(len(b) % 2))


def _ecat(b: bytes) -> object:
    return ethercat.decode(b[14:], strict=bool(len(b) % 2))


def _read_all(raw: bytes) -> object:
    """Open and read every record: the readers stream, so opening alone reads only the header."""
    capture = parse_capture(raw)
    records = sum(1 for _ in capture)
    return records, capture.skipped, capture.findings, capture.total


def _capture(b: bytes) -> object:
    return _read_all(pcap_bytes([(0, b)])[: 24 + 16 + len(b) - len(b) % 5] + b[:3])


def _mutate(raw: bytes, b: bytes) -> bytes:
    """``raw`` with bytes overwritten at places the input ``b`` chooses (3 input bytes each)."""
    buf = bytearray(raw)
    for j in range(0, len(b) - 2, 3):
        buf[(b[j] << 8 | b[j + 1]) % len(buf)] = b[j + 2]
    return bytes(buf[: len(buf) - (b[0] % 7 if b else 0)])


def _pcapng(b: bytes) -> object:
    raw = pcapng_bytes([MarkedRecord(0, b[:40], 1, "c"), MarkedRecord(1, b[40:], None, None)])
    return _read_all(_mutate(raw, b))


def _gzip(b: bytes) -> object:
    raw = gzip.compress(pcap_bytes([(0, b[:30]), (1, b[30:])]), mtime=0)
    return _read_all(_mutate(raw, b[-12:]) + b[:2])


DECODERS: dict[str, Callable[[bytes], object]] = {
    "decode_frame strict": lambda b: decode_frame(b, strict=True),
    "ethernet header": EthernetFrame.from_bytes,
    "powerlink.decode": _epl,
    "ethercat.decode": _ecat,
    "parse_capture": _capture,
    "parse_capture pcapng": _pcapng,
    "parse_capture gzip": _gzip,
    "socketcan record": canbus.CanFrame.from_socketcan,
    "patch_from_bytes": taxel.patch_from_bytes,
}


@pytest.mark.parametrize("name", sorted(DECODERS))
def test_only_decode_errors_escape(name: str) -> None:
    decoder = DECODERS[name]
    for i, data in enumerate(inputs(zlib.crc32(name.encode()))):  # stable across runs
        try:
            decoder(data)
        except DecodeError:
            pass
        except Exception as exc:  # pragma: no cover - the failure report
            pytest.fail(f"{name}: input {i} ({data.hex()}) raised {type(exc).__name__}: {exc}")


def test_capture_mode_keeps_every_byte() -> None:
    for i, data in enumerate(inputs(7)):
        if len(data) < 14:
            continue
        assert decode_frame(data).to_bytes() == data, f"input {i}: {data.hex()}"
