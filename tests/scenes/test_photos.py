"""Photograph textures (scenes.photos) and the files scenes refer to (scenes.assets)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from scenes.assets import AssetError, load_mesh_file, load_photo
from scenes.photos import _mirror_pair, photo_frequency, photo_source, photo_texture
from scenes.spec import SKIMAGE_PHOTOS, TextureSpec
from scenes.textures import make_texture, texture_shape
from stereoforge.errors import ParameterError, SceneError


@pytest.mark.parametrize("name", SKIMAGE_PHOTOS)
def test_every_builtin_photograph_loads_offline(name: str) -> None:
    photo = load_photo(f"skimage:{name}")
    assert photo.dtype == np.uint8 and photo.ndim == 3 and photo.shape[2] == 3
    assert not photo.flags.writeable
    assert 0.003 < photo_frequency(f"skimage:{name}") < 0.25


def test_mean_frequency_of_a_sinusoid_is_its_frequency(tmp_path) -> None:
    # vertical stripes of 0.1 cycles per pixel: the power-weighted mean |f| is 0.1 (Hann
    # leakage is symmetric about the peak)
    x = np.arange(200)
    img = np.repeat((128 + 100 * np.sin(2 * np.pi * 0.1 * x)).astype(np.uint8)[None], 160, 0)
    Image.fromarray(img).save(tmp_path / "s.png")
    assert photo_frequency(str(tmp_path / "s.png")) == pytest.approx(0.1, rel=0.02)


def test_frequency_scales_the_photograph(tmp_path) -> None:
    """A stripe photo of 0.1 c/px mapped at F c/m gives stripes of F c/m on the surface."""
    x = np.arange(200)
    img = np.repeat((128 + 100 * np.sin(2 * np.pi * 0.1 * x)).astype(np.uint8)[None], 160, 0)
    Image.fromarray(img).save(tmp_path / "s.png")
    spec = TextureSpec(kind="image", image=str(tmp_path / "s.png"), frequency=5.0, contrast=1.0)
    tex = make_texture(spec, extent=(4.0, 1.0))  # 50 texels per metre
    row = tex[tex.shape[0] // 2, :, 0].astype(float) - tex[..., 0].mean()
    spectrum = np.abs(np.fft.rfft(row * np.hanning(row.size)))
    peak = np.argmax(spectrum[1:]) + 1
    assert peak / 4.0 == pytest.approx(5.0, abs=0.3)  # cycles per metre of the 4 m patch


def test_photo_texture_is_seeded_and_obeys_contrast() -> None:
    spec = TextureSpec(kind="image", image="skimage:gravel", frequency=30.0, contrast=0.5,
                       mean=0.4, seed=7, angle=20.0)
    a = make_texture(spec, extent=(1.0, 0.5))
    assert a.tobytes() == make_texture(spec, extent=(1.0, 0.5)).tobytes()
    other = make_texture(TextureSpec(**{**spec.__dict__, "seed": 8}), extent=(1.0, 0.5))
    assert a.tobytes() != other.tobytes()  # another offset
    assert a.min() >= np.floor(255 * 0.15) - 1 and a.max() <= np.ceil(255 * 0.65) + 1
    flat = make_texture(TextureSpec(kind="image", image="skimage:gravel", contrast=0.0),
                        extent=(1.0, 0.5))
    assert (flat == flat[0, 0]).all()


def test_texture_shape_caps_and_reduces() -> None:
    # 10 c/m = 145 photo pixels per metre; 300 texels over 4 m = 75 per metre: reduced by ~0.5,
    # the bricks' ~14.5 px period becomes ~7.5 texels and survives
    spec = TextureSpec(kind="image", image="skimage:brick", frequency=10.0)
    h, w = texture_shape(spec, extent=(4.0, 2.0), max_side=300)
    assert (h, w) == (150, 300)
    img = make_texture(spec, extent=(4.0, 2.0), max_side=300)
    assert img.shape[:2] == (h, w) and img.std() > 5  # reduced, not blank


def test_folder_picks_a_file_by_seed(tmp_path) -> None:
    for i, level in enumerate((40, 200)):
        Image.fromarray(np.full((8, 8), level, np.uint8)).save(tmp_path / f"{i}.png")
    (tmp_path / "notes.txt").write_text("not an image")
    picks = {photo_source(TextureSpec(kind="image", image=str(tmp_path), seed=s))
             for s in range(20)}
    assert picks == {str(tmp_path / "0.png"), str(tmp_path / "1.png")}


@pytest.mark.parametrize("make, pattern", [
    (lambda p: str(p / "missing.png"), r"photograph '.*missing\.png' does not exist; check the path"),
    (lambda p: (p / "bad.png").write_text("no") and str(p / "bad.png"),
     r"'.*bad\.png' is not an image Pillow can read"),
    (lambda p: str(p), r"folder '.*' holds no image file"),
    # a header claiming 100 M pixels (Pillow's bomb warning) or 400 M (its error): refused
    # before any pixel is decoded
    (lambda p: (p / "huge.ppm").write_bytes(b"P6\n9999 9999\n255\nab") and str(p / "huge.ppm"),
     r"'.*huge\.ppm' is too large to be a texture .*; give an image of at most \d+ pixels"),
    (lambda p: (p / "huger.ppm").write_bytes(b"P6\n20000 20000\n255\nab") and str(p / "huger.ppm"),
     r"'.*huger\.ppm' is too large to be a texture"),
])
def test_bad_photographs_raise_one_asset_error(tmp_path, make, pattern) -> None:
    spec = TextureSpec(kind="image", image=make(tmp_path))
    with pytest.raises(AssetError, match=pattern) as info:
        make_texture(spec, extent=(1.0, 1.0))
    assert isinstance(info.value, SceneError)


def test_unknown_skimage_name_is_refused_at_construction() -> None:
    with pytest.raises(ParameterError,
                       match=r"skimage:<name>.*got 'bricks'; did you mean 'brick'"):
        TextureSpec(kind="image", image="skimage:bricks")


@pytest.mark.parametrize("kw, pattern", [
    ({"kind": "image"}, r"TextureSpec\.image: expected a photograph for kind 'image'"),
    ({"kind": "noise", "image": "skimage:brick"}, r"drop image, or set kind = 'image'"),
])
def test_image_goes_with_kind_image(kw, pattern) -> None:
    with pytest.raises(ValueError, match=pattern):
        TextureSpec(**kw)


def test_bad_mesh_files_raise_one_asset_error(tmp_path) -> None:
    with pytest.raises(AssetError, match=r"mesh file '.*nope\.ply' does not exist"):
        load_mesh_file(str(tmp_path / "nope.ply"))
    (tmp_path / "x.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 9\n")
    with pytest.raises(AssetError, match=r"mesh file '.*x\.ply' cannot be loaded by trimesh"):
        load_mesh_file(str(tmp_path / "x.ply"))
    (tmp_path / "y.xyz1").write_text("1 2 3\n")
    with pytest.raises(AssetError, match=r"cannot be loaded by trimesh|holds no triangles"):
        load_mesh_file(str(tmp_path / "y.xyz1"))


def test_photo_texture_direct_call_matches_make_texture() -> None:
    spec = TextureSpec(kind="image", image="skimage:coffee", frequency=25.0, seed=3)
    shape = texture_shape(spec, extent=(0.8, 0.6))
    assert (photo_texture(spec, shape, (0.8, 0.6)) == make_texture(spec, extent=(0.8, 0.6))).all()


def test_mesh_own_texture_is_used_only_when_asked(tmp_path) -> None:
    import trimesh

    from scenes.primitives import build_mesh
    from scenes.spec import ObjectSpec, Pose

    quad = trimesh.Trimesh(vertices=[[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]],
                           faces=[[0, 1, 2], [0, 2, 3]], process=False)
    image = Image.fromarray(np.arange(4 * 6 * 3, dtype=np.uint8).reshape(4, 6, 3))
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    quad.visual = trimesh.visual.TextureVisuals(uv=uv, image=image)
    path = tmp_path / "quad.glb"
    quad.export(path)
    pose = Pose(translation=(0.0, 0.0, 2.0))
    own = build_mesh(ObjectSpec("mesh", pose, (1.0,), path=str(path), own_texture=True))
    assert own.metadata["texture_source"] == "own"
    assert (np.asarray(own.visual.material.image) == np.asarray(image)).all()
    np.testing.assert_allclose(own.visual.uv, uv)
    ours = build_mesh(ObjectSpec("mesh", pose, (1.0,), path=str(path)))
    assert ours.metadata["texture_source"] == "generated"
    assert np.asarray(ours.visual.material.image).shape != np.asarray(image).shape
    bare = tmp_path / "bare.ply"
    trimesh.Trimesh(quad.vertices, quad.faces, process=False).export(bare)
    fallback = build_mesh(ObjectSpec("mesh", pose, (1.0,), path=str(bare), own_texture=True))
    assert fallback.metadata["texture_source"] == "generated"  # no texture of its own


# ---------------------------------------------------------------------------- reference formulas
def _mirror(index: np.ndarray, n: int) -> np.ndarray:
    m = np.mod(index, 2 * n)
    return np.where(m >= n, 2 * n - 1 - m, m)


def reference_photo_texture(spec: TextureSpec, shape: tuple[int, int],
                            extent: tuple[float, float]) -> np.ndarray:
    """``photo_texture`` as the module docstring says, over whole (H, W, 3) arrays.

    ``photo_texture`` evaluates it a block of rows and a channel at a time, from cached float
    planes and statistics; the bytes must be these.
    """
    from scenes.photos import _BT601, _CLIP_SIGMAS

    h, w = shape
    width, height = extent
    source = photo_source(spec)
    photo = load_photo(source)
    ppm = spec.frequency / photo_frequency(source)
    texel_ppm = min(w / width, h / height)
    if texel_ppm < ppm:
        factor = texel_ppm / ppm
        ph, pw = photo.shape[:2]
        size = (max(2, round(pw * factor)), max(2, round(ph * factor)))
        photo = np.asarray(Image.fromarray(photo).resize(size, Image.Resampling.BOX))
        ppm *= size[0] / pw
    data = photo.astype(np.float32) / np.float32(255.0)
    grey = load_photo(source).astype(np.float64) @ _BT601 / 255.0
    mu, sigma = float(grey.mean()), float(grey.std())
    rng = np.random.default_rng(spec.seed)
    ph, pw = data.shape[:2]
    off_x, off_y = rng.uniform(size=2) * (pw, ph)
    u = (np.arange(w) + 0.5) * (width / w)
    v = (np.arange(h) + 0.5) * (height / h)
    c, s = math.cos(math.radians(spec.angle)), math.sin(math.radians(spec.angle))
    x = (c * u[None, :] - s * v[:, None]) * ppm + off_x - 0.5
    y = (s * u[None, :] + c * v[:, None]) * ppm + off_y - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    tx, ty = (x - x0).astype(np.float32)[..., None], (y - y0).astype(np.float32)[..., None]
    xa, xb = _mirror(x0.astype(np.int64), pw), _mirror(x0.astype(np.int64) + 1, pw)
    ya, yb = _mirror(y0.astype(np.int64), ph), _mirror(y0.astype(np.int64) + 1, ph)
    top = data[ya, xa] * (1 - tx) + data[ya, xb] * tx
    bottom = data[yb, xa] * (1 - tx) + data[yb, xb] * tx
    rgb = top * (1 - ty) + bottom * ty
    if sigma > 0 and spec.contrast > 0:
        pattern = np.clip((rgb - np.float32(mu)) / np.float32(_CLIP_SIGMAS * sigma), -1.0, 1.0)
        rgb = np.float32(spec.mean) + np.float32(0.5 * spec.contrast) * pattern
    else:
        rgb = np.full_like(rgb, np.float32(spec.mean))
    rgb = np.clip(rgb, 0.0, 1.0) * np.asarray(spec.color, dtype=np.float32) * np.float32(255.0)
    return np.rint(rgb).astype(np.uint8)


@pytest.mark.parametrize(("spec", "extent"), [
    # the flying wall of middlebury-like: 1522 x 2047 texels, the photograph reduced first
    (TextureSpec(kind="image", image="skimage:camera", frequency=7.84, contrast=0.59,
                 mean=0.61, seed=118298827591194411, angle=222.87), (15.07, 11.2)),
    # more texels than photo pixels per metre (no reduction), tinted, rows of one block
    (TextureSpec(kind="image", image="skimage:coffee", frequency=3.0, contrast=1.0, mean=0.5,
                 color=(0.9, 0.5, 0.2), seed=3, angle=-30.0), (0.7, 0.4)),
    (TextureSpec(kind="image", image="skimage:gravel", frequency=40.0, contrast=0.0, mean=0.3,
                 seed=5), (0.5, 0.2)),  # no contrast: one level per channel
    (TextureSpec(kind="image", image="skimage:brick", frequency=12.0, contrast=0.8, seed=9,
                 angle=90.0), (0.05, 3.0)),  # a tall narrow strip: a few texels per row
])
def test_photo_texture_bytes_equal_the_reference_formula(spec: TextureSpec, extent) -> None:
    shape = texture_shape(spec, extent=extent)
    got = photo_texture(spec, shape, extent)
    want = reference_photo_texture(spec, shape, extent)
    assert got.shape == want.shape == (*shape, 3) and got.tobytes() == want.tobytes()


def test_mirror_pair_reflects_both_indices() -> None:
    rng = np.random.default_rng(0)
    for n in (1, 2, 3, 7, 512):
        k = np.concatenate([np.arange(-6 * n - 2, 6 * n + 3),
                            rng.integers(-10**9, 10**9, 5000)]).astype(np.float64)
        first, second = _mirror_pair(k, n)
        assert np.array_equal(first, _mirror(k.astype(np.int64), n))
        assert np.array_equal(second, _mirror(k.astype(np.int64) + 1, n))
