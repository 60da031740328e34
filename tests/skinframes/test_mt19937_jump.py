"""The MT19937 jump ahead against numpy's own generator, output by output."""

from __future__ import annotations

import random

import numpy as np
import pytest

from skinframes import mt19937_jump, taxel


def _generator(seed: int, drawn: int) -> np.random.MT19937:
    """numpy's ``RandomState(seed)`` generator after ``drawn`` 32-bit outputs."""
    state = np.random.RandomState(seed).get_state(legacy=False)["state"]
    bits = np.random.MT19937()
    bits.state = {"bit_generator": "MT19937", "state": {"key": state["key"], "pos": state["pos"]}}
    bits.random_raw(drawn, output=False)
    return bits


def _berlekamp_massey(sequence: list[int]) -> int:
    """The shortest linear recurrence of a GF(2) sequence, as its characteristic polynomial
    (bit i the coefficient of t**i), by Massey (1969), with integers as bit vectors."""
    connection, previous, length, gap = 1, 1, 0, 1
    window = 0  # bit i is sequence[n - i]
    for n, bit in enumerate(sequence):
        window = (window << 1) | bit
        if (connection & window).bit_count() & 1 == 0:
            gap += 1
        elif 2 * length <= n:
            connection, previous = connection ^ (previous << gap), connection
            length, gap = n + 1 - length, 1
        else:
            connection ^= previous << gap
            gap += 1
    # C(D) = 1 + c1 D + ... + cL D^L  ->  p(t) = t^L C(1/t)
    return sum(1 << (length - i) for i in range(length + 1) if connection >> i & 1)


@pytest.mark.parametrize("bit", [0, 31])
def test_the_polynomial_is_the_one_numpys_generator_obeys(bit: int) -> None:
    outputs = _generator(5, 0).random_raw(2 * mt19937_jump.DEGREE + 100)
    # tempering is linear and invertible, so the outputs obey the recurrence's polynomial too
    poly = _berlekamp_massey([int(v) >> bit & 1 for v in outputs])
    assert [e for e in range(poly.bit_length()) if poly >> e & 1] == list(
        mt19937_jump.POLY_EXPONENTS
    )
    assert poly.bit_length() - 1 == mt19937_jump.DEGREE == 19937


_CASES = [
    (seed, drawn, words)
    for seed, drawn in [(0, 0), (1, 1), (2, 300), (3, 623), (4, 624), (5, 625), (6, 100_000)]
    for words in [1, 2, 623, 624, 625, 1247, 1248, 1249, 40_000, 123_457]
] + [
    (r.randrange(2**32), r.randrange(3000), r.randrange(1, 3_000_000))
    for r in [random.Random(23)]
    for _ in range(12)
]


@pytest.mark.parametrize(("seed", "drawn", "words"), _CASES)
def test_a_jump_leaves_the_generator_where_discarding_does(
    seed: int, drawn: int, words: int
) -> None:
    discarded, jumped = _generator(seed, drawn), _generator(seed, drawn)
    discarded.random_raw(words, output=False)
    mt19937_jump.skip(jumped, words, jump_min=0)
    assert jumped.state["state"]["pos"] == discarded.state["state"]["pos"]
    # the next two twists' outputs, word for word
    assert np.array_equal(jumped.random_raw(1500), discarded.random_raw(1500))


def test_no_skip_and_a_short_skip_discard() -> None:
    bits = _generator(9, 10)
    before = bits.state
    mt19937_jump.skip(bits, 0, jump_min=0)
    assert bits.state["state"]["pos"] == before["state"]["pos"]
    assert np.array_equal(bits.state["state"]["key"], before["state"]["key"])
    mt19937_jump.skip(bits, 7)  # below JUMP_MIN_WORDS
    assert np.array_equal(bits.random_raw(5), _generator(9, 17).random_raw(5))
    with pytest.raises(ValueError, match="-1"):
        mt19937_jump.skip(bits, -1)
    # a key whose first word has not been drawn yet (pos 0, as a saved state may hold)
    unread = {"bit_generator": "MT19937", "state": {"key": before["state"]["key"], "pos": 0}}
    bits.state = unread
    mt19937_jump.skip(bits, 0, jump_min=0)
    assert bits.state["state"]["pos"] == 0
    mt19937_jump.skip(bits, 3, jump_min=0)
    discarded = np.random.MT19937()
    discarded.state = unread
    discarded.random_raw(3, output=False)
    assert np.array_equal(bits.random_raw(700), discarded.random_raw(700))


def test_a_long_contact_stream_in_chunks_is_the_one_drawn_at_once() -> None:
    # 160 patches x 192 bytes x 300 samples: 2.3 million words of noise, so the chunked
    # stream jumps to its contacts (JUMP_MIN_WORDS is about a million)
    assert mt19937_jump.JUMP_MIN_WORDS < 160 * 192 * 300 // 4
    whole = taxel.contact_pattern(160, 300, seed=77)
    pieces = np.concatenate(list(taxel.iter_contact_pattern(160, 300, seed=77, chunk=128)))
    assert np.array_equal(pieces, whole)
    assert (whole < taxel.NO_LOAD - 2).any()  # the contacts pressed
