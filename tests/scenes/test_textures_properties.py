"""Property tests of textures (small extents keep images <= 64 px)."""

from __future__ import annotations

import dataclasses
import functools
import importlib.util
import types
from pathlib import Path

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from scenes.spec import TextureSpec
from scenes.strategies import texture_specs

_small = texture_specs().map(lambda t: TextureSpec(kind=t.kind, frequency=8.0, contrast=t.contrast,
                                                   mean=t.mean, color=t.color, seed=t.seed,
                                                   angle=t.angle, image=t.image))
_extent = st.tuples(st.floats(0.1, 0.95), st.floats(0.1, 0.95))  # <= 61 px at 64 px/m


@functools.cache
def _sibling(name: str) -> types.ModuleType:
    """A test module of this directory (not importable by name under --import-mode=importlib)."""
    spec = importlib.util.spec_from_file_location(f"_sibling_{name[:-3]}",
                                                  Path(__file__).with_name(name))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@given(_small, _extent)
def test_texture_is_deterministic_and_in_range(spec: TextureSpec, extent) -> None:
    from scenes.textures import make_texture

    a = make_texture(spec, extent=extent)
    # procedural kinds at 8 px per period; a photograph keeps its own pixels per metre
    assert a.dtype == np.uint8 and a.shape[2] == 3
    assert max(a.shape[:2]) <= 64 or spec.kind == "image"
    assert a.tobytes() == make_texture(spec, extent=extent).tobytes()
    # grey level stays within mean +- contrast / 2 (before the tint), rounding aside
    for channel, tint in enumerate(spec.color):
        lo = 255 * tint * max(0.0, spec.mean - spec.contrast / 2)
        hi = 255 * tint * min(1.0, spec.mean + spec.contrast / 2)
        assert a[:, :, channel].min() >= np.floor(lo) - 1
        assert a[:, :, channel].max() <= np.ceil(hi) + 1


@given(_small, _extent)
def test_texture_image_holds_make_texture_pixels(spec: TextureSpec, extent) -> None:
    """The same pixels for every kind (hand-picked examples:
    ``test_textures.py::test_texture_image_holds_make_texture_pixels``)."""
    from scenes.textures import make_texture, texture_image

    want = make_texture(spec, extent=extent)
    image = texture_image(spec, extent=extent)
    assert image.mode == "RGB" and image.size == (want.shape[1], want.shape[0])
    assert image.tobytes() == want.tobytes()


@given(_small, _extent)
def test_zero_contrast_is_constant(spec: TextureSpec, extent) -> None:
    from scenes.textures import make_texture

    flat = TextureSpec(kind=spec.kind, frequency=8.0, contrast=0.0, mean=spec.mean,
                       color=spec.color, seed=spec.seed, image=spec.image)
    img = make_texture(flat, extent=extent)
    assert (img == img[0, 0]).all()


# frequencies of 0.5 to 40 cycles per metre drawn directly (a filter on texture_specs()'s whole
# positive range rejects most draws and trips hypothesis's filter_too_much health check); the
# procedural kinds only (a photograph is no formula: test_photos.py checks "image")
_moderate = st.tuples(texture_specs(kinds=("noise", "checker", "stripes", "constant")),
                      st.floats(0.5, 40.0)).map(
    lambda drawn: dataclasses.replace(drawn[0], frequency=drawn[1]))


@given(_moderate, _extent)
def test_texture_bytes_equal_the_reference_formulas(spec: TextureSpec, extent) -> None:
    """In-place evaluation changes no byte (hand-picked examples:
    ``test_textures.py::test_make_texture_bytes_equal_the_reference_formulas``)."""
    from scenes.textures import make_texture

    reference_texture = _sibling("test_textures.py").reference_texture
    np.testing.assert_array_equal(make_texture(spec, extent=extent),
                                  reference_texture(spec, extent=extent))


@given(st.integers(1, 96), st.integers(1, 96), st.floats(0.05, 60.0),
       st.tuples(st.floats(0.002, 0.5), st.floats(0.002, 0.5)), st.integers(0, 2**32 - 1))
def test_band_limited_noise_bits_equal_the_reference(h: int, w: int, frequency: float,
                                                     pixel_size, seed: int) -> None:
    """Column-pruned transforms change no bit, signed zeros included (hand-picked examples:
    ``test_textures.py::test_band_limited_noise_bits_equal_the_reference``)."""
    from scenes.textures import band_limited_noise

    reference_noise = _sibling("test_textures.py").reference_noise
    got = band_limited_noise((h, w), frequency=frequency, pixel_size=pixel_size,
                             rng=np.random.default_rng(seed))
    want = reference_noise((h, w), frequency, pixel_size, np.random.default_rng(seed))
    assert got.dtype == want.dtype and got.tobytes() == want.tobytes()


@given(st.integers(1, 700), st.integers(1, 700), st.floats(0.05, 300.0),
       st.floats(1e-4, 0.5), st.floats(1e-4, 0.5))
def test_annulus_equals_the_whole_grid_test(h: int, w: int, frequency: float, du: float,
                                            dv: float) -> None:
    """The per-row windows find every band cell, in order, with the same gains (hand-picked
    examples: ``test_textures.py::test_annulus_cells_and_gains_are_the_whole_grid_test``)."""
    _sibling("test_textures.py").assert_annulus_is_the_reference(h, w, frequency, du, dv)


@given(st.sampled_from(("camera", "coffee", "gravel", "brick")), st.floats(1.0, 60.0),
       st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(-360.0, 360.0),
       st.integers(0, 2**63 - 1), _extent)
def test_photo_texture_bytes_equal_the_reference(name: str, frequency: float, contrast: float,
                                                 mean: float, angle: float, seed: int,
                                                 extent) -> None:
    """Blocks of rows and cached planes change no byte (hand-picked examples:
    ``test_photos.py::test_photo_texture_bytes_equal_the_reference_formula``)."""
    from scenes.photos import photo_texture
    from scenes.textures import texture_shape

    spec = TextureSpec(kind="image", image=f"skimage:{name}", frequency=frequency,
                       contrast=contrast, mean=mean, color=(1.0, 0.7, 0.4), seed=seed,
                       angle=angle)
    shape = texture_shape(spec, extent=extent, max_side=96)  # reduced photographs too
    want = _sibling("test_photos.py").reference_photo_texture(spec, shape, extent)
    assert photo_texture(spec, shape, extent).tobytes() == want.tobytes()


def _is_5_smooth(n: int) -> bool:
    for p in (2, 3, 5):
        while n % p == 0:
            n //= p
    return n == 1


@given(st.integers(1, 5000), st.integers(3, 5000), st.booleans())
def test_texture_sides_are_the_next_allowed_length(n: int, max_side: int, smooth: bool) -> None:
    """Hand-picked examples: ``test_textures.py::test_texture_side_examples``."""
    from scenes.textures import _side

    def allowed(k: int) -> bool:
        return 3 <= k <= max_side and k & (k - 1) != 0 and (not smooth or _is_5_smooth(k))

    m = _side(n, max_side, smooth=smooth)
    assert allowed(m)
    if any(allowed(k) for k in range(max(n, 3), max_side + 1)):  # the next one up
        assert m >= n and not any(allowed(k) for k in range(max(n, 3), m))
    else:  # else the largest one below
        assert not any(allowed(k) for k in range(m + 1, max_side + 1))
