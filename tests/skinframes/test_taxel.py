"""Taxel payloads: patch size (paper eq. 1), byte order, range checks, body layout, contact data."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from skinframes import taxel
from skinframes.errors import FieldRangeError, LengthMismatchError

taxel_arrays = st.integers(0, 16).flatmap(
    lambda t: hnp.arrays(np.int64, (t, 12), elements=st.integers(0, 255))
)


# --- hand-computed facts ----------------------------------------------------------------------------
def test_patch_constants() -> None:
    assert taxel.PATCH_BYTES == 192  # 16 triangles x 12 taxels x 8 bit / 8 (paper eq. 1)
    assert taxel.TRIANGLES_PER_PATCH == 16
    assert taxel.TAXELS_PER_TRIANGLE == 12
    assert taxel.BODY_PATCHES == 160  # paper eq. 2
    assert taxel.NO_LOAD == 0xF0


def test_body_layout() -> None:
    body = taxel.BodyLayout()
    assert body.patches == 160
    assert sum(r.share for r in body.regions) == pytest.approx(1.0)
    assert body.subnetwork("left_arm") == range(0, 16)
    assert body.subnetwork("right_arm") == range(16, 32)
    assert body.subnetwork("left_leg") == range(32, 64)
    assert body.subnetwork("right_leg") == range(64, 96)
    assert body.subnetwork("torso") == range(96, 149)
    assert body.subnetwork("head") == range(149, 160)
    assert body.region_of(0).name == "left_arm"
    assert body.region_of(15).name == "left_arm"
    assert body.region_of(16).name == "right_arm"
    assert body.region_of(148).name == "torso"
    assert body.region_of(159).name == "head"


def test_subnetworks_partition_the_body() -> None:
    body = taxel.BodyLayout()
    patches = [p for r in body.regions for p in body.subnetwork(r.name)]
    assert patches == list(range(160))
    for r in body.regions:
        assert all(body.region_of(p) == r for p in body.subnetwork(r.name))


@pytest.mark.parametrize("patch", [160, 1000, -1])
def test_region_of_out_of_range(patch: int) -> None:
    with pytest.raises(FieldRangeError, match=f"patch {patch} "):
        taxel.BodyLayout().region_of(patch)


def test_unknown_region() -> None:
    with pytest.raises(FieldRangeError):
        taxel.BodyLayout().subnetwork("tail")


# --- patch bytes -----------------------------------------------------------------------------------
@given(taxel_arrays)
def test_patch_bytes_are_triangle_major(taxels: np.ndarray) -> None:
    data = taxel.patch_to_bytes(taxels)
    assert len(data) == 12 * taxels.shape[0]
    for t in range(taxels.shape[0]):
        for k in range(12):
            assert data[12 * t + k] == taxels[t, k]  # byte 12 t + k = taxel k of triangle t


@given(taxel_arrays)
def test_patch_round_trip(taxels: np.ndarray) -> None:
    data = taxel.patch_to_bytes(taxels)
    back = taxel.patch_from_bytes(data)
    assert back.dtype == np.uint8
    assert back.shape == taxels.shape
    assert np.array_equal(back, taxels)
    assert taxel.patch_to_bytes(back) == data


def test_patch_from_bytes_is_a_read_only_view() -> None:
    view = taxel.patch_from_bytes(bytes(range(24)))
    assert not view.flags.writeable
    with pytest.raises(ValueError):
        view[0, 0] = 1


@given(st.binary(max_size=400))
def test_patch_from_bytes_lengths(data: bytes) -> None:
    if len(data) % 12 == 0 and len(data) <= 192:
        assert taxel.patch_from_bytes(data).shape == (len(data) // 12, 12)
    else:
        with pytest.raises(LengthMismatchError):
            taxel.patch_from_bytes(data)


@given(
    st.integers(0, 16).flatmap(
        lambda t: hnp.arrays(
            np.int64,
            (t, 12),
            elements=st.one_of(st.integers(0, 255), st.integers(256, 70000), st.integers(-300, -1)),
        )
    )
)
def test_patch_values_out_of_range_raise(taxels: np.ndarray) -> None:
    # numpy would wrap 256 to 0 and -1 to 255 silently
    if taxels.size and (taxels.min() < 0 or taxels.max() > 255):
        with pytest.raises(FieldRangeError):
            taxel.patch_to_bytes(taxels)
    else:
        assert taxel.patch_to_bytes(taxels) == bytes(int(v) for v in taxels.flat)


@pytest.mark.parametrize("shape", [(12,), (1, 11), (1, 13), (17, 12), (2, 12, 1)])
def test_patch_shape_must_be_triangles_of_12(shape: tuple[int, ...]) -> None:
    with pytest.raises(FieldRangeError):
        taxel.patch_to_bytes(np.zeros(shape, dtype=np.uint8))


@given(
    st.integers(0, 5).flatmap(
        lambda n: st.integers(1, 16).flatmap(
            lambda t: hnp.arrays(np.uint8, (n, t, 12), elements=st.integers(0, 255))
        )
    )
)
def test_pack_patches_rows_are_patch_bytes(patches: np.ndarray) -> None:
    rows = taxel.pack_patches(patches)
    assert rows.shape == (patches.shape[0], patches.shape[1] * 12)
    for i in range(patches.shape[0]):
        assert rows[i].tobytes() == taxel.patch_to_bytes(patches[i])


def test_pack_patches_needs_uint8_triangles() -> None:
    with pytest.raises(FieldRangeError):
        taxel.pack_patches(np.zeros((2, 16, 12), dtype=np.int64))
    with pytest.raises(FieldRangeError):
        taxel.pack_patches(np.zeros((2, 16, 11), dtype=np.uint8))


# --- synthetic contact data ------------------------------------------------------------------------
@given(
    st.integers(1, 4),
    st.integers(1, 3),
    st.integers(0, 2**32 - 1),
    st.integers(0, 4),
    st.integers(1, 16),
)
def test_contact_pattern_is_deterministic_and_in_range(
    patches: int, samples: int, seed: int, contacts: int, triangles: int
) -> None:
    kwargs = {"seed": seed, "contacts": contacts, "triangles": triangles}
    a = taxel.contact_pattern(patches, samples, **kwargs)  # type: ignore[arg-type]
    b = taxel.contact_pattern(patches, samples, **kwargs)  # type: ignore[arg-type]
    assert a.dtype == np.uint8
    assert a.shape == (samples, patches, triangles, 12)
    assert np.array_equal(a, b)
    # pressure only lowers the values; the rest point is NO_LOAD with noise of at most 2
    assert int(a.max()) <= taxel.NO_LOAD + 2


@given(st.integers(0, 255), st.integers(0, 2**32 - 1))
def test_contact_pattern_without_contacts_is_the_baseline(no_load: int, seed: int) -> None:
    a = taxel.contact_pattern(3, 2, seed=seed, contacts=0, no_load=no_load).astype(int)
    assert a.min() >= max(0, no_load - 2)
    assert a.max() <= min(255, no_load + 2)


def test_contact_pattern_seeds_differ() -> None:
    assert not np.array_equal(taxel.contact_pattern(2, seed=1), taxel.contact_pattern(2, seed=2))


def test_contact_pattern_presses() -> None:
    # with contacts, some taxels must read well below the no-load baseline
    a = taxel.contact_pattern(8, 4, seed=0, contacts=3)
    assert int(a.min()) < taxel.NO_LOAD - 20


@pytest.mark.parametrize(
    "kwargs",
    [
        {"patches": 0},
        {"samples": 0},
        {"triangles": 0},
        {"triangles": 17},
        {"no_load": 256},
        {"no_load": -1},
    ],
)
def test_contact_pattern_bad_arguments(kwargs: dict[str, int]) -> None:
    args = {"patches": 1, **kwargs}
    with pytest.raises(FieldRangeError):
        taxel.contact_pattern(**args)


# --- streaming: chunks equal the whole -------------------------------------------------------------
# sha256 of the arrays as the implementation before streaming (commit be6919d) produced them: the
# shared implementation must keep every byte.
PINNED = [
    ("contact_pattern", (1, 1), {"seed": 0}, (1, 1, 16, 12),
     "00764dec4d9b8907922dd622371f3553e233f3b2fd06b1de18c0dd8ac493fea3"),
    ("contact_pattern", (7, 13), {"seed": 3}, (13, 7, 16, 12),
     "11ae861dd9043525d6f5241b025c5ba4ba9a2dbf9611e2409b6c4c2514f4b7db"),
    ("contact_pattern", (160, 40), {"seed": 2**32 - 1}, (40, 160, 16, 12),
     "d3e4e68842d285a83ec9003e05298fb1917ee137d6cbdddd7088b3c6d230c8ea"),
    ("contact_pattern", (5, 9), {"seed": 11, "contacts": 7, "no_load": 1, "triangles": 3},
     (9, 5, 3, 12), "1d4e4aa2cbf9afe31d8dd7a493b0223e9fcf3268a8bf373b7daf74eff15aeb10"),
    ("contact_pattern", (4, 6), {"seed": 8, "contacts": 0, "no_load": 255}, (6, 4, 16, 12),
     "53d96871610a4ae412112373ee12dd68909ab13b7bf6f82a1dfa646836781ec8"),
    ("sample_payloads", (3, 17, 100), {"seed": 4}, (17, 3, 100),
     "c878fca552df1aa36e48ce4b1debeede526d0a4e7af73c6ea4788f7163362cc3"),
    ("sample_payloads", (2, 5, 500), {"seed": 6}, (5, 2, 500),
     "6511a5583d84c879a794d0cef289c6e04976ab0e03e173273686c2a825a4aa90"),
    ("sample_payloads", (21, 30, 192), {"seed": 0}, (30, 21, 192),
     "3939fc2d443f92d53a45d4e5dcbbeba5e7a79af6d516ad506ca47091f73a6ac0"),
    ("sample_payloads", (6, 4, 0), {"seed": 1}, (4, 6, 0),
     "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"),
]  # fmt: skip


@pytest.mark.parametrize(("function", "args", "kwargs", "shape", "digest"), PINNED)
def test_patterns_keep_their_bytes(
    function: str,
    args: tuple[int, ...],
    kwargs: dict[str, int],
    shape: tuple[int, ...],
    digest: str,
) -> None:
    whole = getattr(taxel, function)(*args, **kwargs)
    assert whole.shape == shape
    assert hashlib.sha256(whole.tobytes()).hexdigest() == digest
    iterate = (
        taxel.iter_contact_pattern if function == "contact_pattern" else taxel.iter_sample_payloads
    )
    for chunk in (1, 2, 7):
        pieces = list(iterate(*args, **kwargs, chunk=chunk))
        assert hashlib.sha256(np.concatenate(pieces).tobytes()).hexdigest() == digest


@pytest.mark.parametrize(
    ("patches", "samples", "chunk", "seed", "data_bytes"),
    [
        (1, 1, 1, 0, 192),
        (3, 10, 3, 1, 192),
        (3, 10, 10, 1, 192),
        (3, 10, 11, 1, 192),
        (5, 33, 8, 2**32 - 1, 12),  # a partial patch (< 192)
        (2, 20, 6, 7, 0),
        (4, 25, 4, 9, 500),  # more than a patch (> 192): the patch repeated
        (160, 12, 5, 3, 192),
        (16, 300, 64, 5, 1490),
    ],
)
def test_iter_sample_payloads_equals_sample_payloads(
    patches: int, samples: int, chunk: int, seed: int, data_bytes: int
) -> None:
    whole = taxel.sample_payloads(patches, samples, data_bytes, seed=seed)
    pieces = list(taxel.iter_sample_payloads(patches, samples, data_bytes, seed=seed, chunk=chunk))
    sizes = [len(p) for p in pieces]
    assert sizes == [chunk] * (samples // chunk) + ([samples % chunk] if samples % chunk else [])
    assert all(p.dtype == np.uint8 and p.shape[1:] == (patches, data_bytes) for p in pieces)
    assert np.concatenate(pieces).tobytes() == whole.tobytes()


@given(
    st.integers(1, 5),
    st.integers(1, 12),
    st.integers(1, 13),
    st.integers(0, 2**32 - 1),
    st.integers(0, 5),
    st.sampled_from([0, 1, 2, 128, 253, 254, 255]),
    st.integers(1, 16),
)
def test_iter_contact_pattern_equals_contact_pattern(
    patches: int, samples: int, chunk: int, seed: int, contacts: int, no_load: int, triangles: int
) -> None:
    kwargs = {"seed": seed, "contacts": contacts, "no_load": no_load, "triangles": triangles}
    whole = taxel.contact_pattern(patches, samples, **kwargs)  # type: ignore[arg-type]
    pieces = taxel.iter_contact_pattern(patches, samples, chunk=chunk, **kwargs)  # type: ignore[arg-type]
    assert np.concatenate(list(pieces)).tobytes() == whole.tobytes()


def test_iterators_check_their_arguments_when_called() -> None:
    with pytest.raises(FieldRangeError):
        taxel.iter_sample_payloads(2, 3, 16, chunk=0)
    with pytest.raises(FieldRangeError):
        taxel.iter_sample_payloads(2, 3, -1)
    with pytest.raises(FieldRangeError):
        taxel.iter_contact_pattern(0, 3)
    with pytest.raises(FieldRangeError):
        taxel.iter_contact_pattern(1, 3, seed=2**32)


@pytest.mark.parametrize("no_load", [0, 1, 2, 3, 128, 240, 253, 254, 255])
def test_noise_is_the_byte_mod_5_around_no_load_for_every_byte(no_load: int) -> None:
    raw = np.arange(256, dtype=np.uint8).repeat(1500)  # longer than one scratch pass
    expected = [min(255, max(0, no_load - 2 + b % 5)) for b in raw.tolist()]
    assert taxel._noise_values(raw, no_load).tolist() == expected


@given(
    st.integers(1, 4),
    st.lists(st.integers(1, 7), min_size=1, max_size=6),
    st.integers(0, 2**32 - 1),
    st.sampled_from([1, 12, 192, 500]),
)
def test_payload_stream_cut_anyhow_equals_sample_payloads(
    patches: int, cuts: list[int], seed: int, data_bytes: int
) -> None:
    samples = sum(cuts)
    stream = taxel.PayloadStream(patches, samples, data_bytes, seed=seed)
    pieces = [stream.take(m) for m in cuts]
    whole = taxel.sample_payloads(patches, samples, data_bytes, seed=seed)
    assert np.concatenate(pieces).tobytes() == whole.tobytes()
    with pytest.raises(FieldRangeError, match="0 left"):
        stream.take(1)


@given(
    st.integers(1, 4),
    st.lists(st.tuples(st.integers(1, 7), st.booleans()), min_size=1, max_size=6),
    st.integers(0, 2**32 - 1),
    st.sampled_from([12, 192, 500]),
)
def test_payload_stream_draws_and_fills_as_it_takes(
    patches: int, cuts: list[tuple[int, bool]], seed: int, data_bytes: int
) -> None:
    """``fill(draw(m), m)``, with every draw made before its fill or takes between them (one
    cut being all the samples, or the first of several), is the seeded payloads."""
    samples = sum(m for m, _ in cuts)
    stream = taxel.PayloadStream(patches, samples, data_bytes, seed=seed)
    drawn = [(stream.draw(m), m) for m, _ in cuts]  # all words first, as a thread ahead would
    pieces = [stream.fill(words, m) for words, m in drawn]
    whole = taxel.sample_payloads(patches, samples, data_bytes, seed=seed)
    assert np.concatenate(pieces).tobytes() == whole.tobytes()
    stream = taxel.PayloadStream(patches, samples, data_bytes, seed=seed)
    mixed = [stream.take(m) if take else stream.fill(stream.draw(m), m) for m, take in cuts]
    assert np.concatenate(mixed).tobytes() == whole.tobytes()
    with pytest.raises(FieldRangeError, match="0 left"):
        stream.draw(1)
