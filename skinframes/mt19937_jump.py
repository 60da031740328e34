"""Jump numpy's MT19937 ahead by any number of outputs without drawing them.

The seeded taxels (:mod:`skinframes.taxel`) draw their contacts after all the noise, so a stream
cut into chunks needs the generator as it stands after ``samples x taxels`` bytes: 150 million
outputs for 20,000 samples of the 160-patch skin, 0.5-0.7 s to discard one by one. The jump
takes about 0.1 s whatever the distance.

Method (Haramoto, Matsumoto, Nishimura, Panneton, L'Ecuyer, "Efficient jump ahead for
F2-linear random number generators", INFORMS J. Computing 20(3), 2008): the generator's
recurrence ``x[k+624] = x[k+397] ^ A(x[k] upper bit | x[k+1] lower 31 bits)`` is linear over
GF(2) with characteristic polynomial ``p`` of degree 19937. If ``t**N mod p = sum c_i t**i``,
every bit sequence the recurrence makes obeys ``x[k+N] = XOR of x[k+i] over c_i = 1``. The
state after N words, ``x[N..N+623]``, is therefore the XOR of the windows ``x[i..i+623]`` of the
first 20,560 words, one window per set coefficient: no 19937-bit matrix, no Horner loop.
"""

from __future__ import annotations

from functools import cache
from typing import Final

import numpy as np
import numpy.typing as npt

__all__ = ["skip"]

N_WORDS: Final = 624  # MT19937's n (Matsumoto & Nishimura 1998): 624 32-bit words of state
DEGREE: Final = 19937  # the recurrence's order: 624 * 32 - 31 bits of state (r = 31)

# The exponents of the characteristic polynomial p(t) of MT19937's recurrence (135 terms),
# lowest first, found by Berlekamp-Massey from the generator's own output;
# tests/skinframes/test_mt19937_jump.py derives it again from numpy's MT19937 and compares.
POLY_EXPONENTS: Final = (
    0, 1189, 1416, 1585, 1643, 1870, 2493, 2773, 3000, 3227, 3454, 3681, 3908, 4135, 4362,
    4753, 5661, 6337, 6569, 7129, 7477, 7525, 7583, 7752, 7979, 8206, 9505, 9901, 9969, 10128,
    10693, 10761, 10920, 11089, 11147, 11157, 11215, 11321, 11374, 11384, 11485, 11611, 11712,
    11717, 11838, 11881, 11944, 11997, 12277, 12335, 12393, 12504, 12509, 12620, 12673, 12731,
    12736, 12789, 12905, 12958, 12963, 13137, 13185, 13190, 13243, 13301, 13412, 13528, 13533,
    13639, 13697, 13760, 13813, 13866, 14093, 14151, 14209, 14320, 14325, 14436, 14547, 14552,
    14605, 14721, 14774, 14779, 14953, 15001, 15006, 15059, 15117, 15228, 15344, 15349, 15455,
    15513, 15576, 15629, 15682, 15909, 15967, 16025, 16136, 16141, 16252, 16363, 16368, 16421,
    16537, 16590, 16595, 16817, 16822, 16875, 16933, 17044, 17160, 17271, 17329, 17445, 17498,
    17725, 17783, 17841, 17952, 18068, 18179, 18237, 18406, 18633, 18691, 18860, 19087, 19314,
    19937,
)  # fmt: skip

# below this many outputs, discarding them one by one is faster than the jump (about 5 ms)
JUMP_MIN_WORDS: Final = 1 << 20
_ROWS: Final = 64  # state words combined per numpy pass (64 x ~10,000 gathered words)


def skip(bits: np.random.MT19937, words: int, *, jump_min: int = JUMP_MIN_WORDS) -> None:
    """Advance ``bits`` past ``words`` 32-bit outputs, as ``bits.random_raw(words,
    output=False)`` does (the same state afterwards), jumping when ``words >= jump_min``."""
    if words < 0:
        raise ValueError(f"cannot skip {words} outputs")
    if words < max(jump_min, 1):
        bits.random_raw(words, output=False)
        return
    state = bits.state["state"]
    ahead = int(state["pos"]) + words  # outputs counted from the start of the current key
    blocks = (ahead - 1) // N_WORDS  # twists between the current key and the one wanted
    key = _jumped_key(np.asarray(state["key"], np.uint32), N_WORDS * blocks)
    bits.state = {
        "bit_generator": "MT19937",
        "state": {"key": key, "pos": (ahead - 1) % N_WORDS + 1},
    }


def _jumped_key(key: npt.NDArray[np.uint32], n: int) -> npt.NDArray[np.uint32]:
    """The words ``x[n..n+623]`` of the sequence whose first 624 words are ``key``."""
    if n == 0:
        return key.copy()
    x = _words(key, DEGREE + N_WORDS)
    coefficients = _t_power_mod_p(n)
    terms = np.flatnonzero(
        np.unpackbits(
            np.frombuffer(coefficients.to_bytes((DEGREE + 7) // 8, "little"), np.uint8),
            bitorder="little",
        )
    )
    out = np.empty(N_WORDS, np.uint32)
    for lo in range(0, N_WORDS, _ROWS):
        j = np.arange(lo, min(lo + _ROWS, N_WORDS))
        out[lo : lo + len(j)] = np.bitwise_xor.reduce(x[terms[None, :] + j[:, None]], axis=1)
    return out


def _words(key: npt.NDArray[np.uint32], count: int) -> npt.NDArray[np.uint32]:
    """The first ``count`` words of the recurrence from ``key``: the key, then each twist's
    new key (numpy's own twist)."""
    bits = np.random.MT19937()
    bits.state = {"bit_generator": "MT19937", "state": {"key": key, "pos": N_WORDS}}
    keys = [key]
    for _ in range(-(-count // N_WORDS) - 1):
        bits.random_raw(N_WORDS, output=False)  # one twist, all its outputs discarded
        keys.append(np.asarray(bits.state["state"]["key"], np.uint32))
    return np.concatenate(keys)[:count]


def _t_power_mod_p(n: int) -> int:
    """``t**n mod p(t)`` over GF(2), bit i the coefficient of t**i (square and shift)."""
    p = _poly()
    r = 1
    for bit in bin(n)[2:]:
        r = _reduce(_square(r))
        if bit == "1":
            r <<= 1
            if r >> DEGREE:
                r ^= p
    return r


def _square(a: int) -> int:
    """``a(t)**2`` over GF(2): each coefficient moves from t**i to t**(2i)."""
    raw = np.frombuffer(a.to_bytes((a.bit_length() + 7) // 8 or 1, "little"), np.uint8)
    return int.from_bytes(_spread()[raw].astype("<u2").tobytes(), "little")


def _reduce(r: int) -> int:
    """``r mod p`` for p sparse: ``t**19937 = sum of its other terms``, folded from the top
    (each fold shortens r by 19937 - 19314 = 623 bits)."""
    low = (1 << DEGREE) - 1
    while r >> DEGREE:
        high = r >> DEGREE
        r &= low
        for e in POLY_EXPONENTS[:-1]:
            r ^= high << e
    return r


@cache
def _poly() -> int:
    """p(t) as an integer, bit i the coefficient of t**i."""
    return sum(1 << e for e in POLY_EXPONENTS)


@cache
def _spread() -> npt.NDArray[np.uint16]:
    """Byte b -> the 16 bits with b's bit i at bit 2i (GF(2) squaring of 8 coefficients)."""
    b = np.arange(256, dtype=np.uint16)
    out = np.zeros(256, np.uint16)
    for i in range(8):
        out |= ((b >> i) & 1) << (2 * i)
    return out
