"""Taxel payloads: one patch = 16 triangles x 12 taxels x 8 bit = 192 bytes (paper eq. 1).

A patch is a microcontroller reading up to 16 triangular modules over I2C; each triangle has 12
capacitive taxels. Values are 8-bit and *inverted* as the iCub skin firmware sends them: an
untouched taxel reads the no-load baseline (0xF0 in the robot configurations) and pressure lowers
the value (see ../shared/reference/can.md 1.3). The byte order of a patch payload is
triangle-major: byte ``12 * t + k`` is taxel k of triangle t, as the host reassembles CAN frames
(``index = triangle * 12 + k``).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Final

import numpy as np
import numpy.typing as npt

from skinframes import mt19937_jump
from skinframes.errors import FieldRangeError, LengthMismatchError

__all__ = [
    "BODY_PATCHES",
    "CONTACT_THRESHOLD",
    "NO_LOAD",
    "PATCH_BYTES",
    "REGIONS",
    "TAXELS_PER_TRIANGLE",
    "TRIANGLES_PER_PATCH",
    "BodyLayout",
    "ContactStream",
    "PayloadStream",
    "Region",
    "contact_pattern",
    "in_contact",
    "iter_contact_pattern",
    "iter_sample_payloads",
    "pack_patches",
    "patch_from_bytes",
    "patch_to_bytes",
    "sample_payloads",
]

TRIANGLES_PER_PATCH: Final = 16  # 4 I2C buses x 4 triangles (paper II-A)
TAXELS_PER_TRIANGLE: Final = 12
BITS_PER_TAXEL: Final = 8
PATCH_BYTES: Final = TRIANGLES_PER_PATCH * TAXELS_PER_TRIANGLE * BITS_PER_TAXEL // 8  # 192, eq. 1
BODY_PATCHES: Final = 160  # eq. 2: about 1 m^2 of skin
NO_LOAD: Final = 0xF0  # robots-configuration skinSpec noLoad (can.md 1.3)
CONTACTS: Final = 3  # pressure blobs sliding along the skin in a synthetic sample


def patch_to_bytes(taxels: npt.ArrayLike) -> bytes:
    """Serialise a (T, 12) array of 8-bit taxels (T <= 16 triangles; a partial patch is fine).

    Raises:
        FieldRangeError: wrong shape, or a value outside 0..255 (numpy would wrap it silently).
    """
    arr = np.asarray(taxels)
    if arr.ndim != 2 or arr.shape[1] != TAXELS_PER_TRIANGLE or arr.shape[0] > TRIANGLES_PER_PATCH:
        raise FieldRangeError(f"taxels: shape {arr.shape}, expected (T<=16, 12)")
    if arr.size and (arr.min() < 0 or arr.max() > 0xFF):
        raise FieldRangeError("taxels: values must be 0..255")
    return arr.astype(np.uint8).tobytes()


def patch_from_bytes(data: bytes) -> npt.NDArray[np.uint8]:
    """The (T, 12) uint8 view of a patch payload of 12*T bytes (read-only: it views ``data``)."""
    if len(data) % TAXELS_PER_TRIANGLE or len(data) > PATCH_BYTES:
        raise LengthMismatchError(
            f"taxels: {len(data)} bytes is not a whole number of 12-taxel triangles (<= 192)"
        )
    return np.frombuffer(data, dtype=np.uint8).reshape(-1, TAXELS_PER_TRIANGLE)


def pack_patches(patches: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """(n, T, 12) taxels -> (n, 12*T) payload rows, one per patch, in patch order."""
    arr = np.asarray(patches)
    if arr.dtype != np.uint8 or arr.ndim != 3 or arr.shape[2] != TAXELS_PER_TRIANGLE:
        raise FieldRangeError(
            f"patches: dtype {arr.dtype}, shape {arr.shape}; need uint8 (n, T, 12)"
        )
    return arr.reshape(arr.shape[0], arr.shape[1] * TAXELS_PER_TRIANGLE)


# --- contact ---------------------------------------------------------------------------------
NOISE: Final = 2  # +- sensor noise around NO_LOAD in contact_pattern
# A taxel is pressed when it reads below NO_LOAD by more than five times the noise: noise alone
# never crosses it (values are inverted: pressure lowers them).
CONTACT_THRESHOLD: Final = NO_LOAD - 5 * NOISE  # 230


def in_contact(taxels: npt.NDArray[np.uint8]) -> npt.NDArray[np.bool_]:
    """Per triangle (the last axis holds its 12 taxels): any taxel below CONTACT_THRESHOLD."""
    pressed: npt.NDArray[np.bool_] = np.any(np.asarray(taxels) < CONTACT_THRESHOLD, axis=-1)
    return pressed


@dataclass(frozen=True, slots=True)
class Region:
    """A subnetwork of the skin (paper II-A: arm 10 %, leg 20 %, torso 33 % of the surface)."""

    name: str
    share: float  # fraction of the body's skin
    patches: int


# Paper II-A (after [18]): an arm carries ~10 % of the skin (16 patches), a leg ~20 %, the torso
# ~33 % (the paper's "up to 55"); the remaining ~7 % (head, neck) completes the 160 patches.
REGIONS: Final = (
    Region("left_arm", 0.10, 16),
    Region("right_arm", 0.10, 16),
    Region("left_leg", 0.20, 32),
    Region("right_leg", 0.20, 32),
    Region("torso", 0.33, 53),
    Region("head", 0.07, 11),
)


@dataclass(frozen=True, slots=True)
class BodyLayout:
    """Which patches make the skin and which subnetwork each belongs to."""

    regions: tuple[Region, ...] = REGIONS

    @property
    def patches(self) -> int:
        """Total number of patches (160 for the default body)."""
        return sum(r.patches for r in self.regions)

    def region_of(self, patch: int) -> Region:
        """The region of patch number ``patch`` (0-based, regions in order)."""
        rest = patch
        for r in self.regions:
            if 0 <= rest < r.patches:
                return r
            rest -= r.patches
        raise FieldRangeError(f"patch {patch} is not one of the layout's {self.patches} patches")

    def subnetwork(self, name: str) -> range:
        """Patch numbers of the region called ``name``."""
        start = 0
        for r in self.regions:
            if r.name == name:
                return range(start, start + r.patches)
            start += r.patches
        raise FieldRangeError(f"no region {name!r}; known: {[r.name for r in self.regions]}")


def contact_pattern(
    patches: int,
    samples: int = 1,
    *,
    seed: int = 0,
    contacts: int = CONTACTS,
    no_load: int = NO_LOAD,
    triangles: int = TRIANGLES_PER_PATCH,
) -> npt.NDArray[np.uint8]:
    """Seeded synthetic skin data: (samples, patches, triangles, 12) uint8, inverted values.

    Every taxel rests at ``no_load`` plus sensor noise of +-2; ``contacts`` pressure blobs per
    sample slide along the skin (taxels numbered patch-major, as if unfolded to a line) and lower
    the values under them, deepest at the centre, as pressure does on the iCub skin. Integer
    arithmetic and numpy's frozen legacy generator (RandomState) make the bytes the same on
    every machine and numpy version. :func:`iter_contact_pattern` yields the same samples in
    chunks, in memory that does not grow with ``samples``.
    """
    (whole,) = iter_contact_pattern(
        patches,
        samples,
        seed=seed,
        contacts=contacts,
        no_load=no_load,
        triangles=triangles,
        chunk=max(samples, 1),
    )
    return whole


def iter_contact_pattern(
    patches: int,
    samples: int = 1,
    *,
    seed: int = 0,
    contacts: int = CONTACTS,
    no_load: int = NO_LOAD,
    triangles: int = TRIANGLES_PER_PATCH,
    chunk: int = 256,
) -> Iterator[npt.NDArray[np.uint8]]:
    """:func:`contact_pattern` in consecutive (m <= chunk, patches, triangles, 12) pieces.

    The pieces concatenate to ``contact_pattern(...)`` byte for byte. The generator draws all
    the noise first (``samples`` x taxels bytes) and the contacts after it; with more than one
    chunk a second generator skips the noise to draw the contacts up front, and the first one
    yields the noise chunk by chunk. Both steps consume whole 32-bit words (a sample has
    12 * triangles * patches bytes, a multiple of 4), so the stream is the one drawn at once.
    """
    _check_pattern(patches, samples, seed, contacts, no_load, triangles)
    if chunk < 1:
        raise FieldRangeError(f"contact_pattern: chunk of {chunk} samples, need >= 1")
    return _contact_chunks(patches, samples, seed, contacts, no_load, triangles, chunk)


def _check_pattern(
    patches: int, samples: int, seed: int, contacts: int, no_load: int, triangles: int
) -> None:
    """FieldRangeError unless the arguments of :func:`contact_pattern` are in range."""
    if patches < 1 or samples < 1 or contacts < 0 or not 1 <= triangles <= TRIANGLES_PER_PATCH:
        raise FieldRangeError(
            "contact_pattern: need patches >= 1, samples >= 1, contacts >= 0, 1 <= triangles <= 16"
        )
    if not 0 <= no_load <= 0xFF:
        raise FieldRangeError("contact_pattern: no_load must be 0..255")
    if not 0 <= seed <= 0xFFFFFFFF:
        raise FieldRangeError(f"contact_pattern: seed {seed} outside 0..2**32-1")


def _contact_chunks(
    patches: int, samples: int, seed: int, contacts: int, no_load: int, triangles: int, chunk: int
) -> Iterator[npt.NDArray[np.uint8]]:
    """The pattern in fixed chunks (arguments checked by the callers)."""
    stream = ContactStream(patches, samples, seed, contacts, no_load, triangles)
    for first in range(0, samples, chunk):
        yield stream.take(min(chunk, samples - first))


class ContactStream:
    """The one implementation of :func:`contact_pattern`: ``take(m)`` gives the next m samples.

    The generator draws all the noise first (``samples`` x taxels bytes) and the contacts after
    it; unless the first take asks for every sample, a second generator skips the noise to draw
    the contacts up front, and the first one yields the noise take by take. Both steps consume
    whole 32-bit words (a sample has 12 * triangles * patches bytes, a multiple of 4), so the
    stream is the one drawn at once, however it is cut. Arguments are checked by the callers.
    """

    def __init__(
        self, patches: int, samples: int, seed: int, contacts: int, no_load: int, triangles: int
    ) -> None:
        self.shape = (patches, triangles, TAXELS_PER_TRIANGLE)
        self.samples = samples
        self._seed, self._contacts, self._no_load = seed, contacts, no_load
        self._bits = _mt19937(np.random.RandomState(seed))
        self._words = np.random.Generator(self._bits)
        self._length = patches * triangles * TAXELS_PER_TRIANGLE  # taxels (= bytes) per sample
        self._blobs: _Contacts | None = None
        self._drawn = 0  # samples whose words are drawn
        self._first = 0  # samples filled

    def take(self, m: int) -> npt.NDArray[np.uint8]:
        """The next ``m`` samples, (m, patches, triangles, 12) uint8 (m >= 1, within samples)."""
        self._before_draw(m)
        # RandomState.bytes(n): n // 4 32-bit outputs, little-endian (length is a multiple of
        # 12); drawn from the bit generator directly, 1.5x faster, the same bytes
        # Generator.integers over the full 32-bit range returns the raw outputs as uint32 (no
        # uint64 array to convert): the same words, 1.4x faster than random_raw
        values = np.empty(m * self._length, np.uint8)
        for lo in range(0, len(values), _NOISE_STEP):  # a cache's size at a time
            part = values[lo : lo + _NOISE_STEP]
            words = self._words.integers(0, 1 << 32, len(part) // 4, dtype=np.uint32)
            _noise_values(words.astype("<u4", copy=False).view(np.uint8), self._no_load, out=part)
        self._after_draw(m)
        return self._pressed(values, m)

    def draw(self, m: int) -> npt.NDArray[np.uint32]:
        """The generator's words for the next ``m`` samples, for :meth:`fill` (which another
        thread may run: ``fill(draw(m), m)`` is ``take(m)``, in the same order)."""
        self._before_draw(m)
        words = self._words.integers(0, 1 << 32, m * self._length // 4, dtype=np.uint32)
        self._after_draw(m)
        return words

    def fill(self, words: npt.NDArray[np.uint32], m: int) -> npt.NDArray[np.uint8]:
        """The ``m`` samples of :meth:`draw`'s ``words`` (calls in the order of the draws)."""
        raw = words.astype("<u4", copy=False).view(np.uint8)
        values = np.empty(m * self._length, np.uint8)
        for lo in range(0, len(values), _NOISE_STEP):  # a cache's size at a time
            part = values[lo : lo + _NOISE_STEP]
            _noise_values(raw[lo : lo + len(part)], self._no_load, out=part)
        return self._pressed(values, m)

    def _before_draw(self, m: int) -> None:
        """Check ``m``; before a first draw of fewer than all samples, draw the contacts by a
        jump past the noise."""
        if not 1 <= m <= self.samples - self._drawn:
            raise FieldRangeError(
                f"contact stream: {m} samples asked, {self.samples - self._drawn} left"
            )
        if self._contacts and self._blobs is None and m < self.samples:
            skipped = _skip_words(self._seed, self.samples * self._length // 4)
            self._blobs = _Contacts.draw(skipped, self._contacts, self._length, self._no_load)

    def _after_draw(self, m: int) -> None:
        self._drawn += m
        if self._contacts and self._blobs is None:  # one draw: all the noise is drawn
            rng = np.random.RandomState()
            rng.set_state({"bit_generator": "MT19937", "state": self._bits.state["state"]})
            self._blobs = _Contacts.draw(rng, self._contacts, self._length, self._no_load)

    def _pressed(self, values: npt.NDArray[np.uint8], m: int) -> npt.NDArray[np.uint8]:
        """The noise ``values`` of the next ``m`` samples, pressed by the contacts."""
        if self._blobs is not None:
            self._blobs.press(values, self._first, m)
        self._first += m
        return values.reshape(m, *self.shape)


_NOISE_STEP: Final = 1 << 17  # bytes per pass (a multiple of 4): stays in the CPU's cache


def _noise_values(
    raw: npt.NDArray[np.uint8], no_load: int, *, out: npt.NDArray[np.uint8] | None = None
) -> npt.NDArray[np.uint8]:
    """``no_load - 2 + raw % 5`` (noise of -2..+2), clipped to 0..255, as uint8 (into ``out``).

    Inside 2..253 nothing can wrap, and ``raw % 5`` is ``raw - 5 * (raw // 5)`` in uint8, exact
    for every byte (the tests check all 256), a cache's size at a time: numpy divides a uint8
    array by a scalar with SIMD, 2.6x faster than ``raw % 5`` widened to uint16 and 5x faster
    than numpy's uint8 remainder.
    """
    if out is None:
        out = np.empty_like(raw)
    if not 2 <= no_load <= 0xFF - 2:
        out[:] = np.clip((raw % 5).astype(np.int16) + (no_load - 2), 0, 0xFF)
        return out
    step = min(_NOISE_STEP, len(raw))
    q = np.empty(step, np.uint8)
    five, low = np.uint8(5), np.uint8(no_load - 2)
    for lo in range(0, len(raw), step):
        part = raw[lo : lo + step]
        qs, res = q[: len(part)], out[lo : lo + len(part)]
        np.floor_divide(part, five, out=qs)
        np.multiply(qs, five, out=qs)
        np.subtract(part, qs, out=res)
        np.add(res, low, out=res)
    return out


def _mt19937(rng: np.random.RandomState) -> np.random.MT19937:
    """A bit generator in the state of ``rng`` (the MT19937 key and position)."""
    state = rng.get_state(legacy=False)["state"]
    bits = np.random.MT19937()
    bits.state = {"bit_generator": "MT19937", "state": {"key": state["key"], "pos": state["pos"]}}
    return bits


def _skip_words(seed: int, words: int) -> np.random.RandomState:
    """``RandomState(seed)`` after ``words`` 32-bit outputs, as ``bytes(4 * words)`` leaves it
    (:func:`skinframes.mt19937_jump.skip`: a jump, not a discard, for long streams)."""
    rng = np.random.RandomState(seed)
    bits = _mt19937(rng)
    mt19937_jump.skip(bits, words)
    rng.set_state({"bit_generator": "MT19937", "state": bits.state["state"]})
    return rng


@dataclass(frozen=True, slots=True)
class _Contacts:
    """Pressure blobs: start taxel, speed (taxels per sample), half-width (taxels), depth."""

    start: npt.NDArray[np.int64]
    speed: npt.NDArray[np.int64]
    half: npt.NDArray[np.int64]
    depth: npt.NDArray[np.int64]
    length: int

    @classmethod
    def draw(
        cls, rng: np.random.RandomState, contacts: int, length: int, no_load: int
    ) -> _Contacts:
        """Draw the blobs, in this order, from ``rng`` (past the noise)."""
        start = rng.randint(0, length, size=contacts)
        speed = rng.randint(-3, 4, size=contacts)
        half = rng.randint(TAXELS_PER_TRIANGLE, 4 * TAXELS_PER_TRIANGLE + 1, size=contacts)
        depth = rng.randint(80, max(81, no_load + 1), size=contacts)
        return cls(start, speed, half, depth, length)

    def press(self, values: npt.NDArray[np.uint8], first: int, samples: int) -> None:
        """Lower ``values`` (samples x length, from sample ``first``) under the blobs, in place.

        Overlapping blobs sum their pressure and the taxel saturates at 0. The pressures are
        never negative, so ``max(v - a - b, 0) == max(max(v - a, 0) - b, 0)``: the blobs press
        one after the other, each a contiguous run of distinct taxels per sample (no sort).
        """
        length = self.length
        flat = values.reshape(-1)
        t = np.arange(first, first + samples, dtype=np.int64)  # the absolute sample index
        rows = ((t - first) * length)[:, None]
        for start, speed, half, depth in zip(
            self.start.tolist(),
            self.speed.tolist(),
            self.half.tolist(),
            self.depth.tolist(),
            strict=True,
        ):
            offsets = np.arange(1 - half, half, dtype=np.int64)  # the taxels under the blob
            amount = depth * (half - np.abs(offsets)) // half  # deepest at the centre
            idx = ((start + speed * t) % length)[:, None] + offsets[None, :]
            inside = (idx >= 0) & (idx < length)
            at = (rows + idx)[inside]
            lowered = flat[at].astype(np.int64) - np.broadcast_to(amount, idx.shape)[inside]
            flat[at] = np.maximum(lowered, 0)


def sample_payloads(
    patches: int, samples: int, data_bytes: int, *, seed: int = 0
) -> npt.NDArray[np.uint8]:
    """(samples, patches, data_bytes) payload bytes: seeded contact patterns, one row per patch.

    ``data_bytes`` up to 192 takes the first bytes of the patch (a partial patch: whole
    triangles first); more than 192 repeats the patch's bytes (for payload sweeps beyond one
    patch). :func:`iter_sample_payloads` yields the same rows in chunks.
    """
    (whole,) = iter_sample_payloads(patches, samples, data_bytes, seed=seed, chunk=max(samples, 1))
    return whole


def iter_sample_payloads(
    patches: int, samples: int, data_bytes: int, *, seed: int = 0, chunk: int = 256
) -> Iterator[npt.NDArray[np.uint8]]:
    """:func:`sample_payloads` in consecutive (m <= chunk, patches, data_bytes) uint8 pieces.

    The pieces concatenate to ``sample_payloads(...)`` byte for byte; the memory used is that of
    one chunk, whatever ``samples`` is.
    """
    if data_bytes < 0:
        raise FieldRangeError(f"payload of {data_bytes} bytes")
    pieces = iter_contact_pattern(patches, samples, seed=seed, chunk=chunk)
    return (_payload_rows(piece, data_bytes) for piece in pieces)


class PayloadStream:
    """:func:`sample_payloads` m samples at a time: ``take(m)`` -> (m, patches, data_bytes).

    The takes concatenate to ``sample_payloads(patches, samples, data_bytes, seed=seed)`` byte
    for byte, however they are cut; memory is that of one take.
    """

    def __init__(self, patches: int, samples: int, data_bytes: int, *, seed: int = 0) -> None:
        if data_bytes < 0:
            raise FieldRangeError(f"payload of {data_bytes} bytes")
        _check_pattern(patches, samples, seed, CONTACTS, NO_LOAD, TRIANGLES_PER_PATCH)
        self._stream = ContactStream(patches, samples, seed, CONTACTS, NO_LOAD, TRIANGLES_PER_PATCH)
        self._data_bytes = data_bytes

    def take(self, m: int) -> npt.NDArray[np.uint8]:
        """The next ``m`` samples' payload rows."""
        return _payload_rows(self._stream.take(m), self._data_bytes)

    def draw(self, m: int) -> npt.NDArray[np.uint32]:
        """The generator's words for the next ``m`` samples (:meth:`ContactStream.draw`)."""
        return self._stream.draw(m)

    def fill(self, words: npt.NDArray[np.uint32], m: int) -> npt.NDArray[np.uint8]:
        """The payload rows of :meth:`draw`'s ``words``: ``fill(draw(m), m)`` is ``take(m)``;
        the fills may run on another thread than the draws, in the same order."""
        return _payload_rows(self._stream.fill(words, m), self._data_bytes)


def _payload_rows(taxels: npt.NDArray[np.uint8], data_bytes: int) -> npt.NDArray[np.uint8]:
    """(m, patches, 16, 12) taxels -> (m, patches, data_bytes) payload rows."""
    m, patches = taxels.shape[:2]
    flat = taxels.reshape(m, patches, PATCH_BYTES)
    if data_bytes <= PATCH_BYTES:
        return np.ascontiguousarray(flat[:, :, :data_bytes])
    reps = -(-data_bytes // PATCH_BYTES)
    return np.ascontiguousarray(np.tile(flat, (1, 1, reps))[:, :, :data_bytes])
