"""Renderer: backend selection and errors, lazy GL imports, validation, context reuse."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import textwrap
from collections.abc import Callable

import numpy as np
import pytest
import scenes
import trimesh
from PIL import Image

import synth.render.backend as backend_mod
from synth.pair import render_pair
from synth.render.renderer import GLBackendError, Renderer
from synth.camera.rig import StereoRig


# ---------------------------------------------------------------------------- no GL needed
def test_unknown_backend_is_a_value_error() -> None:
    with pytest.raises(ValueError, match=r"one of 'auto', 'egl', 'osmesa'.*'nonsense'"):
        Renderer(64, 48, backend="nonsense")


def test_bad_size_is_a_value_error() -> None:
    with pytest.raises(ValueError, match="width must be a positive int"):
        Renderer(0, 48)


@pytest.mark.parametrize("threads", [-1, 1.5, True, "2"])
def test_bad_threads_is_a_value_error(threads: object) -> None:
    with pytest.raises(ValueError, match=r"threads must be None .* or an int >= 0"):
        Renderer(64, 48, threads=threads)  # type: ignore[arg-type]


def _fake_probe(monkeypatch: pytest.MonkeyPatch, result: Callable[[str], tuple[str, str]]) -> None:
    """The probe subprocess answers ``result(backend)`` (stdout, stderr) with exit status 1."""
    def fake_run(cmd, **kwargs):
        return subprocess.CompletedProcess(cmd, 1, *result(cmd[-1]))

    monkeypatch.setattr(backend_mod, "platform_in_use", lambda: None)
    monkeypatch.setattr(backend_mod.subprocess, "run", fake_run)
    monkeypatch.setattr(backend_mod, "probe_backend", backend_mod.probe_backend.__wrapped__)


def test_no_backend_error_names_each_backend_and_fix(monkeypatch: pytest.MonkeyPatch) -> None:
    # a failure the probe does not recognise: its last line, and the Debian packages
    _fake_probe(monkeypatch, lambda b: ("", f"Traceback ...\nOSError: cannot load lib{b}\n"))
    with pytest.raises(GLBackendError) as info:
        Renderer(64, 48, backend="auto")
    msg = str(info.value)
    assert isinstance(info.value, RuntimeError)
    assert "egl: OSError: cannot load libegl" in msg
    assert "osmesa: OSError: cannot load libosmesa" in msg
    assert "libegl1 libegl-mesa0 libgl1-mesa-dri" in msg and "libosmesa6" in msg


def test_a_missing_python_package_gets_pip_not_apt(monkeypatch: pytest.MonkeyPatch) -> None:
    # what the probe prints on a GLBackendError of synth.render.context: the problem and its own fix
    tagged = backend_mod._PROBE_TAG + json.dumps(["PyOpenGL is not installed", "pip install x"])
    _fake_probe(monkeypatch, lambda b: (f"{tagged}\n", ""))
    with pytest.raises(GLBackendError) as info:
        Renderer(64, 48, backend="osmesa")
    assert str(info.value) == ("no OpenGL backend could start; tried:\n"
                               "  osmesa: PyOpenGL is not installed\n    fix: pip install x")


def test_probe_finds_synth_where_this_process_did(monkeypatch: pytest.MonkeyPatch) -> None:
    """The probe subprocess imports synth.render.context: its PYTHONPATH leads with synth's parent."""
    seen = {}

    def fake_run(cmd, *, env, **kwargs):
        seen.update(env=env, cmd=cmd)
        return subprocess.CompletedProcess(cmd, 0, "llvmpipe", "")

    monkeypatch.setattr(backend_mod.subprocess, "run", fake_run)
    monkeypatch.setenv("PYTHONPATH", "/elsewhere")
    assert backend_mod.probe_backend.__wrapped__("egl") is None
    import synth

    src = os.path.dirname(os.path.dirname(os.path.abspath(synth.__file__)))  # synth's parent
    assert seen["env"]["PYTHONPATH"].split(os.pathsep) == [src, "/elsewhere"]
    assert seen["env"]["PYOPENGL_PLATFORM"] == "egl" and seen["cmd"][-1] == "egl"


def test_locked_platform_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(backend_mod, "platform_in_use", lambda: "glx")
    with pytest.raises(GLBackendError, match=r"already imported.*'glx'.*fresh process"):
        Renderer(64, 48)


def test_importing_synth_does_not_import_gl() -> None:
    """PYOPENGL_PLATFORM must be settable after `import synth`: GL imports are lazy."""
    code = ("import sys, synth.render.renderer, synth.pair, synth.camera.rig; "
            "print(sorted(m for m in ('OpenGL', 'pyrender') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# ---------------------------------------------------------------------------- GL
def _quad(z: float = 2.0, half: float = 2.0) -> trimesh.Trimesh:
    """Fronto-parallel textured quad: image top half red, bottom half blue."""
    img = np.zeros((64, 64, 3), dtype=np.uint8)
    img[:32, :, 0] = 255
    img[32:, :, 2] = 255
    v = [[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]]
    uv = [[0, 1], [1, 1], [1, 0], [0, 0]]  # OpenGL uv: v = 1 is image row 0; world y is down
    visual = trimesh.visual.TextureVisuals(uv=uv, image=Image.fromarray(img))
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], visual=visual, process=False)


def test_a_pil_rgb_texture_comes_out_as_its_rgb_and_a_fourth_byte() -> None:
    from synth.render.meshes import texture_array

    rgb = np.random.default_rng(0).integers(0, 256, (5, 7, 3), dtype=np.uint8)
    out = texture_array(Image.fromarray(rgb))
    assert out.shape == (5, 7, 4) and out.dtype == np.uint8 and out.flags.c_contiguous
    np.testing.assert_array_equal(out[..., :3], rgb)
    np.testing.assert_array_equal(texture_array(rgb), rgb)  # arrays: as they are


@pytest.mark.gl
def test_texture_sources_give_the_same_pixels(renderer: Renderer) -> None:
    """RGB and RGBA PIL images (alpha ignored) and grey images are one texture."""
    rig = StereoRig.default(32, 24)
    base = _quad()
    reference = renderer.render_view([base], rig, eye="left").color
    rgb = np.asarray(base.visual.material.image)
    rgba = _quad()
    rgba.visual.material.image = Image.fromarray(
        np.dstack([rgb, np.full(rgb.shape[:2], 7, np.uint8)]))
    np.testing.assert_array_equal(renderer.render_view([rgba], rig, eye="left").color, reference)
    grey = _quad()
    grey.visual.material.image = Image.fromarray(rgb[:, :, 0])  # mode "L": red channel only
    got = renderer.render_view([grey], rig, eye="left").color
    assert np.array_equal(got[..., 0], got[..., 1]) and np.array_equal(got[..., 1], got[..., 2])
    np.testing.assert_array_equal(got[..., 0], reference[..., 0])


@pytest.mark.gl
def test_mesh_list_depth_and_texture_orientation(renderer: Renderer) -> None:
    rig = StereoRig.default(32, 24)
    view = renderer.render_view([_quad()], rig, eye="left")
    assert view.color.shape == (24, 32, 3) and view.color.dtype == np.uint8
    assert view.depth.shape == (24, 32) and view.depth.dtype == np.float32
    np.testing.assert_allclose(view.depth, 2.0, rtol=1e-6)
    top, bottom = view.color[:10].reshape(-1, 3).mean(0), view.color[-10:].reshape(-1, 3).mean(0)
    assert top[0] > 100 > top[2] and bottom[2] > 100 > bottom[0]


def _plain_quad(x0: float, x1: float, z: float = 2.0) -> trimesh.Trimesh:
    """Untextured fronto-parallel quad over X in [x0, x1], Y in [-5, 5] (no visual colour)."""
    v = [[x0, -5.0, z], [x1, -5.0, z], [x1, 5.0, z], [x0, 5.0, z]]
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


@pytest.mark.gl
def test_untextured_colour_is_the_shade_and_edges_are_antialiased(renderer: Renderer) -> None:
    # The default light (0.3, 0.5, 1) on a quad facing the camera: shade = ambient 0.3 +
    # 0.7 cos, display-encoded (1/2.2); the background is black.
    rig = StereoRig(width=32, height=24, fx=20.0, fy=20.0, cx=15.5, cy=11.5, baseline=0.1)
    # left edge through the centre of column 10: x = 20 X / 2 + 15.5 = 10 at X = -0.55
    view = renderer.render_view([_plain_quad(-0.55, 5.0)], rig, eye="left")
    cos = 1.0 / np.linalg.norm([0.3, 0.5, 1.0])
    expected = 255 * (0.3 + 0.7 * cos) ** (1 / 2.2)  # 243.6
    inner, edge = view.color[:, 12:].astype(float), view.color[:, 10].astype(float)
    assert np.abs(inner - expected).max() <= 1.0  # grey: the same in all channels
    assert (view.color[:, :9] == 0).all()
    # 4x MSAA resolved to the mean of the samples: half of them are covered
    assert (edge > 0.25 * expected).all() and (edge < 0.75 * expected).all()


@pytest.mark.gl
def test_closed_meshes_are_culled_without_changing_the_image(renderer: Renderer) -> None:
    """Back faces of closed meshes are culled in both passes: no visible change."""
    rig = StereoRig(width=48, height=32, fx=60.0, fy=60.0, cx=23.5, cy=15.5, baseline=0.1)
    closed = scenes.build_meshes(scenes.get_preset("flying", seed=3))
    assert not closed[0].metadata["double_sided"]  # flying's objects are closed solids
    open_ = [m.copy() for m in closed]
    for m in open_:
        m.metadata["double_sided"] = True
    a = renderer.render_view(closed, rig, eye="right")
    b = renderer.render_view(open_, rig, eye="right")
    np.testing.assert_array_equal(np.isfinite(a.depth), np.isfinite(b.depth))
    fin = np.isfinite(a.depth)
    # where a back face won a float32 tie on a silhouette, the front face wins now
    np.testing.assert_allclose(a.depth[fin], b.depth[fin], rtol=1e-4)
    assert (a.depth != b.depth).mean() <= 0.01
    assert (np.abs(a.color.astype(int) - b.color) > 1).mean() <= 0.01
    # culling is really on: a closed mesh wound inside out shows its far side
    inside_out = closed[0].copy()
    inside_out.faces = inside_out.faces[:, ::-1]
    z = closed[0].vertices[:, 2]
    obj = closed[0].vertices.mean(0)
    aimed = StereoRig(width=16, height=12, fx=60.0, fy=60.0, cx=7.5 - 60.0 * obj[0] / obj[2],
                      cy=5.5 - 60.0 * obj[1] / obj[2], baseline=0.1)
    front = renderer.render_view([closed[0]], aimed, eye="left").depth[6, 8]
    back = renderer.render_view([inside_out], aimed, eye="left").depth[6, 8]
    assert z.min() <= front < back <= z.max()


@pytest.mark.gl
def test_no_surface_is_inf(renderer: Renderer) -> None:
    rig = StereoRig.default(32, 24)
    view = renderer.render_view([_quad(half=0.2)], rig, eye="right")  # small quad in the middle
    assert np.isinf(view.depth[0, 0]) and np.isfinite(view.depth[12, 16])
    pair = render_pair([_quad(half=0.2)], rig, renderer=renderer)
    assert np.isinf(pair.disp_left[0, 0]) and pair.mask_left[0, 0] == 0
    assert np.isinf(pair.disp_right[0, 0])


@pytest.mark.gl
def test_input_validation(renderer: Renderer) -> None:
    rig = StereoRig.default(32, 24)
    with pytest.raises(ValueError, match="eye must be 'left' or 'right'"):
        renderer.render_view([_quad()], rig, eye="centre")
    with pytest.raises(TypeError, match="SceneSpec or a sequence of trimesh.Trimesh"):
        renderer.render_view("boxes", rig, eye="left")
    with pytest.raises(TypeError, match="rig must be a StereoRig"):
        renderer.render_view([_quad()], (32, 24), eye="left")
    with pytest.raises(ValueError, match="no meshes"):
        renderer.render_view([], rig, eye="left")
    with pytest.raises(ValueError, match=r"'mesh\[0\]'.*behind the left camera"):
        renderer.render_view([_quad(z=-1.0)], rig, eye="left")
    with pytest.raises(ValueError, match=r"outside the rig's \[near, far\]"):
        renderer.render_view([_quad(z=200.0)], rig, eye="left")


@pytest.mark.gl
def test_same_scene_and_seed_same_bytes(renderer: Renderer) -> None:
    rig = StereoRig(width=48, height=32, fx=80.0, fy=80.0, cx=23.5, cy=15.5, baseline=0.1)
    a = render_pair(scenes.get_preset("flying", seed=7), rig, renderer=renderer)
    b = render_pair(scenes.get_preset("flying", seed=7), rig, renderer=renderer)
    for name in ("left", "right", "disp_left", "disp_right", "depth_left", "mask_left"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name
    c = render_pair(scenes.get_preset("flying", seed=8), rig, renderer=renderer)
    assert c.left.tobytes() != a.left.tobytes()
    timings: dict[str, float] = {}
    with renderer.pass_timings(timings):  # benchmarks time the passes: the bytes stay
        d = render_pair(scenes.get_preset("flying", seed=7), rig, renderer=renderer)
    for name in ("left", "right", "disp_left", "disp_right", "depth_left", "mask_left"):
        assert getattr(d, name).tobytes() == getattr(a, name).tobytes(), name
    assert {k for k in timings if not k.endswith("_cpu")} == {"meshes", "upload", "colour",
                                                              "depth"}
    assert all(v >= 0 for v in timings.values()) and timings["colour"] > 0
    before = dict(timings)
    render_pair(scenes.get_preset("flying", seed=7), rig, renderer=renderer)
    assert timings == before  # outside the block nothing is timed


@pytest.mark.gl
def test_one_context_for_many_renders(renderer: Renderer, monkeypatch: pytest.MonkeyPatch) -> None:
    opened = []
    original = Renderer.__init__

    def spy(self: Renderer, *args: object, **kwargs: object) -> None:
        opened.append(args)
        original(self, *args, **kwargs)

    monkeypatch.setattr(Renderer, "__init__", spy)
    rig = StereoRig.default(32, 24)
    spec = scenes.get_preset("boxes")
    first = render_pair(spec, rig, renderer=renderer)
    for _ in range(15):
        again = render_pair(spec, rig, renderer=renderer)
        assert again.left.tobytes() == first.left.tobytes()
        assert again.disp_left.tobytes() == first.disp_left.tobytes()
    assert opened == []  # every render went through the one context
    # without a renderer, render_pair opens (and closes) its own: same result
    own = render_pair(spec, rig)
    assert len(opened) == 1
    assert own.left.tobytes() == first.left.tobytes()
    assert own.disp_left.tobytes() == first.disp_left.tobytes()


@pytest.mark.gl
def test_closed_renderer_refuses() -> None:
    with Renderer(16, 12) as r:
        pass
    with pytest.raises(RuntimeError, match="closed"):
        r.render_view([_quad()], StereoRig.default(16, 12), eye="left")
    r.close()  # idempotent


_BACKEND_SCRIPT = textwrap.dedent("""
    import json, sys, hashlib, scenes
    from synth.pair import render_pair
    from synth.camera.rig import StereoRig
    rig = StereoRig.default(32, 24)
    p = render_pair(scenes.get_preset("slanted_plane"), rig, backend=sys.argv[1])
    print(json.dumps({"backend": p.meta["backend"],
                      "disp": hashlib.sha1(p.disp_left.tobytes()).hexdigest(),
                      "left": p.left.astype(float).tolist()}))
""")


@pytest.mark.gl
@pytest.mark.slow
def test_egl_and_osmesa_agree() -> None:
    """Both backends (each needs its own process) give the same ground truth and colour."""
    results = {}
    for backend in ("egl", "osmesa"):
        out = subprocess.run([sys.executable, "-c", _BACKEND_SCRIPT, backend],
                             capture_output=True, text=True)
        if out.returncode != 0:
            pytest.fail(f"backend {backend} failed:\n{out.stderr[-2000:]}")
        results[backend] = json.loads(out.stdout)
        assert results[backend]["backend"] == backend
    assert results["egl"]["disp"] == results["osmesa"]["disp"]
    diff = np.abs(np.array(results["egl"]["left"]) - np.array(results["osmesa"]["left"]))
    assert diff.max() <= 1


@pytest.mark.gl
def test_resolve_backend_names_a_backend_and_skipping_the_probe_works(renderer: Renderer) -> None:
    from synth.render.renderer import resolve_backend

    name = resolve_backend("auto")
    assert name == renderer.backend
    with Renderer(16, 12, backend=name, probe=False) as r:
        assert r.backend == name
    with pytest.raises(ValueError, match="backend must be one of"):
        resolve_backend("vulkan")


_THREADS_SCRIPT = textwrap.dedent("""
    import hashlib, json, os, sys
    import scenes
    from synth.pair import render_pair
    from synth.render.renderer import Renderer
    from synth.camera.rig import StereoRig

    threads = int(sys.argv[1])
    rig = StereoRig.default(96, 72)
    with Renderer(96, 72, threads=threads) as r:
        pair = render_pair(scenes.get_preset("flying", seed=3), rig, renderer=r)
        env_after = os.environ.get("LP_NUM_THREADS")
    digest = hashlib.sha256(pair.left.tobytes() + pair.right.tobytes()
                            + pair.disp_left.tobytes() + pair.disp_right.tobytes()).hexdigest()
    try:
        Renderer(32, 24, threads=threads + 1)
        late = "accepted"
    except ValueError as exc:
        late = str(exc)
    with Renderer(32, 24, threads=threads):  # the value in effect is accepted again
        pass
    print(json.dumps({"digest": digest, "env_after": env_after, "late": late}))
""")


@pytest.mark.gl
@pytest.mark.slow
def test_rasterizer_threads_do_not_change_the_images(renderer: Renderer) -> None:
    """Pixels do not depend on llvmpipe's thread count; the count is fixed per process."""
    rig = StereoRig.default(96, 72)
    pair = render_pair(scenes.get_preset("flying", seed=3), rig, renderer=renderer)
    here = hashlib.sha256(pair.left.tobytes() + pair.right.tobytes()
                          + pair.disp_left.tobytes() + pair.disp_right.tobytes()).hexdigest()
    env = {k: v for k, v in os.environ.items() if k != "LP_NUM_THREADS"}
    env["PYOPENGL_PLATFORM"] = renderer.backend
    for threads in (0, 2):
        out = subprocess.run([sys.executable, "-c", _THREADS_SCRIPT, str(threads)],
                             capture_output=True, text=True, env=env)
        if out.returncode != 0:
            pytest.fail(f"threads={threads} failed:\n{out.stderr[-2000:]}")
        res = json.loads(out.stdout)
        assert res["digest"] == here, f"threads={threads} changed the pixels"
        assert res["env_after"] is None  # the caller's environment is restored
        assert f"threads={threads + 1} cannot take effect" in res["late"]
        assert f"with {threads} rasterizer threads" in res["late"]
