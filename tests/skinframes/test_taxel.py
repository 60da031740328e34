"""Taxel payloads: patch size (paper eq. 1), byte order, range checks, body layout, contact data."""

from __future__ import annotations

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
