"""Both GL backends, each in a fresh process (PyOpenGL binds one platform per process).

EGL and OSMesa contexts come from :mod:`synth.render.context`; these tests render through each one,
through every way EGL gets a display and makes a context current, and check that the bytes are
the same everywhere and reproduce the golden references, and that errors name the right fix.
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = ROOT / "golden"

# Renders in a fresh process and prints what the tests compare, as JSON.
_RENDER = textwrap.dedent("""
    import hashlib, json, sys
    import scenes
    from synth.render import renderer as render
    from synth.render.context import EGLContext
    from synth.jobs.golden import golden_check
    from synth.pair import render_pair
    from synth.camera.rig import StereoRig

    backend, displays, pbuffer, golden = sys.argv[1], sys.argv[2], sys.argv[3] == "1", sys.argv[4]
    if displays != "-":  # one way to get the EGL display and make the context current
        render.open_context = lambda b: EGLContext(displays=(displays,), pbuffer=pbuffer)
    rig = StereoRig.default(96, 72)
    digests = {}
    with render.Renderer(96, 72, backend=backend) as r:
        gl = [r.backend, r.gl_renderer, r.gl_version, getattr(r._context, "display_kind", None)]
        for preset, seed in (("flying", 3), ("moebius", 0), ("terrain", 1)):
            p = render_pair(scenes.get_preset(preset, seed=seed), rig, renderer=r)
            digests[preset] = {name: hashlib.sha256(getattr(p, name).tobytes()).hexdigest()
                               for name in ("left", "right", "depth_left", "disp_left",
                                            "disp_right", "mask_left")}
    report = golden_check(golden, backend=backend, matchers=False) if golden != "-" else None
    print(json.dumps({
        "gl": gl, "digests": digests,
        "golden": None if report is None else {
            "failures": list(report.failures),
            "render": [[d.scene, d.image_max_abs, d.disparity_max_abs, d.boundary_pixels,
                        d.mask_changed] for d in report.render]},
        "pyrender_loaded": any(m.split(".")[0] == "pyrender" for m in sys.modules),
    }))
""")


def _render(backend: str, displays: str = "-", pbuffer: bool = False, golden: bool = False,
            env: dict[str, str] | None = None) -> dict:
    args = [backend, displays, "1" if pbuffer else "0", str(GOLDEN) if golden else "-"]
    out = subprocess.run([sys.executable, "-c", _RENDER, *args], capture_output=True, text=True,
                         env=env)
    if out.returncode != 0:
        pytest.fail(f"rendering on {args} failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout)


@pytest.fixture(scope="module")
def runs() -> dict[str, dict]:
    return {b: _render(b, golden=True) for b in ("egl", "osmesa")}


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("backend", ["egl", "osmesa"])
def test_each_backend_reproduces_the_golden_scenes(runs: dict[str, dict], backend: str) -> None:
    """Within the golden tolerances anywhere; exactly where the golden's Mesa is the one here."""
    run = runs[backend]
    assert run["gl"][0] == backend and not run["pyrender_loaded"]
    assert run["golden"]["failures"] == []
    assert len(run["golden"]["render"]) == 4
    stored = json.loads((GOLDEN / "manifest.json").read_text())["gl"]
    if [stored["GL_RENDERER"], stored["GL_VERSION"]] == run["gl"][1:3]:
        for scene, image, disparity, boundary, mask in run["golden"]["render"]:
            assert (image, disparity, boundary, mask) == (0, 0, 0, 0), scene


@pytest.mark.gl
@pytest.mark.slow
def test_egl_and_osmesa_give_identical_bytes(runs: dict[str, dict]) -> None:
    assert runs["egl"]["gl"][1:3] == runs["osmesa"]["gl"][1:3]  # the same Mesa driver
    assert runs["egl"]["digests"] == runs["osmesa"]["digests"]
    assert runs["egl"]["golden"]["render"] == runs["osmesa"]["golden"]["render"]


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("displays", ["device", "surfaceless", "default"])
@pytest.mark.parametrize("pbuffer", [False, True], ids=["no-surface", "pbuffer"])
def test_every_egl_display_and_surface_gives_the_same_bytes(
        runs: dict[str, dict], displays: str, pbuffer: bool) -> None:
    # Mesa's default display follows EGL_PLATFORM; without a window system only surfaceless works
    env = dict(os.environ, EGL_PLATFORM="surfaceless") if displays == "default" else None
    run = _render("egl", displays, pbuffer, env=env)
    assert run["gl"][3] == displays
    assert run["digests"] == runs["egl"]["digests"]


_CONTEXTS = textwrap.dedent("""
    import sys
    import numpy as np
    import scenes
    from synth.render import context as glcontext
    from synth.pair import render_pair
    from synth.render.renderer import Renderer
    from synth.camera.rig import StereoRig

    backend = sys.argv[1]
    rig = StereoRig.default(32, 24)
    spec = scenes.get_preset("boxes")
    with Renderer(32, 24, backend=backend) as kept:
        before = render_pair(spec, rig, renderer=kept).left
        other = Renderer(32, 24, backend=backend, probe=False)
        render_pair(spec, rig, renderer=other)
        other.close()
        other.close()
        assert np.array_equal(render_pair(spec, rig, renderer=kept).left, before)
        context = glcontext.open_context(backend)
        context.destroy()
        context.destroy()
        try:
            context.make_current()
        except RuntimeError as exc:
            assert "destroyed" in str(exc), exc
        else:
            raise AssertionError("a destroyed context was made current")
        assert np.array_equal(render_pair(spec, rig, renderer=kept).left, before)
    print("ok")
""")


@pytest.mark.gl
@pytest.mark.parametrize("backend", ["egl", "osmesa"])
def test_closing_one_context_leaves_the_others_working(backend: str) -> None:
    """destroy() is idempotent and destroys only its own context (no eglTerminate)."""
    out = subprocess.run([sys.executable, "-c", _CONTEXTS, backend], capture_output=True,
                         text=True)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-3000:]


# ---------------------------------------------------------------------------- errors
def _site(tmp_path: Path, code: str) -> dict[str, str]:
    """An environment whose Python runs ``code`` at start-up (a sitecustomize module)."""
    (tmp_path / "sitecustomize.py").write_text(textwrap.dedent(code))
    return dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (str(tmp_path), os.environ.get("PYTHONPATH")) if p))


_NO_PYOPENGL = """
    import sys
    class _NoOpenGL:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] == "OpenGL":
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    sys.meta_path.insert(0, _NoOpenGL())
"""
_NO_LIBRARY = """
    import ctypes
    _load = ctypes.CDLL.__init__
    def _without(self, name, *args, **kwargs):
        if name and str(name).startswith("{prefix}"):
            raise OSError(f"{{name}}: cannot open shared object file: No such file or directory")
        _load(self, name, *args, **kwargs)
    ctypes.CDLL.__init__ = _without
"""
_CLI_RENDER = ("import sys; from synth.cli import main; "
               "sys.argv = ['stereoforge', 'render', 'boxes', '--width', '16', '--height', '12', "
               "'--out', sys.argv[1], '--backend', sys.argv[2]]; main()")


@pytest.mark.parametrize("backend", ["egl", "osmesa"])
def test_missing_pyopengl_asks_for_pip_not_apt(tmp_path: Path, backend: str) -> None:
    out = subprocess.run([sys.executable, "-c", _CLI_RENDER, str(tmp_path / "out"), backend],
                         capture_output=True, text=True, env=_site(tmp_path, _NO_PYOPENGL))
    assert out.returncode != 0
    assert f"{backend}: PyOpenGL is not installed" in out.stderr
    assert "fix: pip install 'PyOpenGL>=3.1.7'" in out.stderr
    assert "apt-get" not in out.stderr


@pytest.mark.parametrize(("backend", "prefix", "missing", "packages"), [
    ("egl", "libEGL", "libEGL.so.1", "libegl1 libegl-mesa0 libgl1-mesa-dri"),
    ("osmesa", "libOSMesa", "libOSMesa.so", "libosmesa6"),
])
def test_missing_system_library_names_it_and_the_debian_packages(
        tmp_path: Path, backend: str, prefix: str, missing: str, packages: str) -> None:
    out = subprocess.run([sys.executable, "-c", _CLI_RENDER, str(tmp_path / "out"), backend],
                         capture_output=True, text=True,
                         env=_site(tmp_path, _NO_LIBRARY.format(prefix=prefix)))
    assert out.returncode != 0
    assert f"{backend}: {missing} not found" in out.stderr
    assert f"fix (Debian): apt-get install {packages}" in out.stderr
    assert "pip install" not in out.stderr


@pytest.mark.gl
def test_pyopengl_without_osmesa_attribs_asks_for_a_newer_pyopengl() -> None:
    """PyOpenGL 3.1.0 (pyrender's pin) has no OSMesaCreateContextAttribs: say which to install."""
    code = textwrap.dedent("""
        import os
        os.environ["PYOPENGL_PLATFORM"] = "osmesa"
        import OpenGL.osmesa
        del OpenGL.osmesa.OSMesaCreateContextAttribs  # as in PyOpenGL 3.1.0
        from synth.render.backend import GLBackendError
        from synth.render.context import OSMesaContext
        try:
            OSMesaContext()
        except GLBackendError as exc:
            print(exc.problem, "|", exc.fix)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert "has no OSMesaCreateContextAttribs" in out.stdout, out.stderr[-2000:]
    assert out.stdout.strip().endswith("| pip install 'PyOpenGL>=3.1.7'")


def test_bad_egl_displays_is_a_value_error() -> None:
    from synth.render.context import EGLContext, open_context

    with pytest.raises(ValueError, match=r"displays must be a non-empty sequence of .*'x11'"):
        EGLContext(displays=("x11",))
    with pytest.raises(ValueError, match="backend must be one of"):
        open_context("glx")


# ---------------------------------------------------------------------------- no pyrender
def _pyrender_lines(source: str) -> list[int]:
    """Lines that import pyrender or hand its name to an importer (find_spec, a version list)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module]
        elif isinstance(node, ast.Call):
            names = [a.value for a in node.args
                     if isinstance(a, ast.Constant) and isinstance(a.value, str)]
        elif isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            names = [e.value for e in node.elts
                     if isinstance(e, ast.Constant) and isinstance(e.value, str)]
        if any(n == "pyrender" or n.startswith("pyrender.") for n in names):
            found.append(node.lineno)
    return sorted(found)


def test_no_module_imports_pyrender() -> None:
    offenders = {str(p.relative_to(ROOT)): lines for p in sorted((ROOT / "src").rglob("*.py"))
                 if (lines := _pyrender_lines(p.read_text()))}
    assert offenders == {}


def test_the_pyrender_check_sees_every_form() -> None:
    sample = ("import pyrender\nfrom pyrender.platforms import egl\n"
              "spec = importlib.util.find_spec('pyrender')\nDISTS = ('numpy', 'pyrender')\n"
              '"""pyrender is not used"""\nimport trimesh\n')
    assert _pyrender_lines(sample) == [1, 2, 3, 4]
