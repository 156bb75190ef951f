"""Presets: registry, determinism, seeds, depth range and full-frame coverage."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.presets import PRESETS, Preset, frame_cover_size, get_preset, list_presets
from scenes.primitives import build_meshes
from scenes.spec import SceneSpec
from scenes.serialize import dumps_toml, loads_toml

# Default rig the presets are framed for (see scenes.presets).
_W, _H, _F, _CX, _CY, _B = 640, 480, 600.0, 319.5, 239.5, 0.1
_NAMES = [name for name, _ in list_presets()]


def _rays_hit(origin: np.ndarray, dirs: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Which rays hit any triangle (Moller-Trumbore, all pairs, float64)."""
    e1 = tri[:, 1] - tri[:, 0]
    e2 = tri[:, 2] - tri[:, 0]
    hit = np.zeros(len(dirs), dtype=bool)
    for k, d in enumerate(dirs):
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-15
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = origin - tri[:, 0]
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        hit[k] = (ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)).any()
    return hit


def test_registry_lists_the_required_presets() -> None:
    required = {"fronto_plane", "slanted_plane", "boxes", "moebius", "textureless", "flying",
                "terrain"}
    assert required <= set(PRESETS)
    for name, description in list_presets():
        assert isinstance(PRESETS[name], Preset) and PRESETS[name].name == name
        assert description and "\n" not in description


def test_unknown_preset_lists_valid_ones() -> None:
    with pytest.raises(ValueError, match=r"unknown preset 'nope'; valid presets: fronto_plane, "):
        get_preset("nope")
    with pytest.raises(TypeError, match="seed must be an int"):
        get_preset("boxes", seed=1.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="seed must be in"):
        get_preset("boxes", seed=-1)
    with pytest.raises(TypeError):
        PRESETS["x"] = PRESETS["boxes"]  # type: ignore[index]


@pytest.mark.parametrize("name", _NAMES)
def test_preset_is_deterministic_and_seed_changes_textures(name: str) -> None:
    a, b, c = get_preset(name, seed=1), get_preset(name, seed=1), get_preset(name, seed=2)
    assert isinstance(a, SceneSpec) and a == b and a.name == name and a.seed == 1
    assert loads_toml(dumps_toml(a)) == a
    textured = [o for o in a.objects if o.texture.kind != "constant"]
    if textured:
        seeds_a = [o.texture.seed for o in a.objects]
        seeds_c = [o.texture.seed for o in c.objects]
        assert seeds_a != seeds_c
    else:  # textureless: nothing random to change
        assert [o for o in a.objects] == [o for o in c.objects]


def test_flying_layout_depends_on_seed() -> None:
    a, b = get_preset("flying", seed=0), get_preset("flying", seed=1)
    assert [o.pose for o in a.objects[:-1]] != [o.pose for o in b.objects[:-1]]
    kinds = {o.kind for s in range(5) for o in get_preset("flying", seed=s).objects[:-1]}
    assert kinds == {"box", "sphere", "cylinder"}
    for seed in range(5):  # random layouts stay in front of the camera and the wall
        meshes = build_meshes(get_preset("flying", seed=seed))
        z = np.concatenate([m.vertices[:, 2] for m in meshes[:-1]])
        assert 0.5 < z.min() and z.max() < meshes[-1].vertices[0, 2]


def test_textureless_uses_two_grey_levels() -> None:
    spec = get_preset("textureless")
    assert {o.texture.kind for o in spec.objects} == {"constant"}
    assert len({o.texture.mean for o in spec.objects}) == len(spec.objects) == 2


@pytest.mark.parametrize("name", _NAMES)
def test_preset_meshes_are_in_front_and_fill_both_views(name: str) -> None:
    spec = get_preset(name, seed=3)
    meshes = build_meshes(spec)
    assert len(meshes) == len(spec.objects)
    verts = np.concatenate([m.vertices for m in meshes])
    # within the default near and far planes (0.1, 100 m); the room starts just ahead of the
    # rig, the backdrops lie behind objects up to 50 and 60 m
    lo, hi = {"room": (0.1, 50.0), "backdrop": (0.5, 100.0),
              "outdoor": (0.1, 100.0)}.get(name, (0.5, 50.0))
    assert verts[:, 2].min() > lo and verts[:, 2].max() < hi
    for m in meshes:
        assert max(m.visual.material.image.size) <= 2048
    tri = np.concatenate([m.vertices[m.faces] for m in meshes])
    # rays through the corners, edges and interior of both 640 x 480 views
    xs, ys = np.meshgrid(np.linspace(0, _W - 1, 9), np.linspace(0, _H - 1, 7))
    dirs = np.stack([(xs.ravel() - _CX) / _F, (ys.ravel() - _CY) / _F, np.ones(xs.size)], 1)
    for origin in (np.zeros(3), np.array([_B, 0.0, 0.0])):
        hit = _rays_hit(origin, dirs, tri)
        if spec.sky is None:
            assert hit.all(), f"{name}: {np.count_nonzero(~hit)} rays from {origin} miss"
        else:  # a sky at infinity above the horizon; every ray well below it meets the ground
            down = dirs[:, 1] > 0.05
            assert hit[down].all(), f"{name}: {np.count_nonzero(~hit[down])} rays down miss"
            assert not hit.all(), f"{name}: no ray sees the sky"


def test_frame_cover_size_hand_values() -> None:
    w, h = frame_cover_size(2.0, margin=1.0)
    assert w == pytest.approx(2 * 320 / 600 * 2.0 + 0.1) and h == pytest.approx(1.6)
