"""The renderer: one GL context for its lifetime, two passes per view (colour, exact depth).

Both passes are our own shader programs in one GL context (made by
:mod:`synth.render.context` from PyOpenGL's EGL or OSMesa bindings). Colour: a view-independent Lambert shading baked into
per-vertex colours times a mipmapped texture, 4x MSAA resolved to the pixel
average, so a surface point has the same colour in both views. Ground truth:
no multisampling, a 32-bit float colour target that receives the camera-space
depth ``Z`` interpolated (perspective-correctly) at each pixel centre, and a
32-bit float depth buffer. See ``docs/ground-truth.md`` for why.

PyOpenGL is imported lazily: ``PYOPENGL_PLATFORM`` must be set before the first
``import OpenGL`` and cannot change afterwards. Backend choice lives in
:mod:`synth.render.backend`, context creation in :mod:`synth.render.context`, scene-to-mesh
preparation in :mod:`synth.render.meshes`.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from stereoforge.errors import ParameterError
from synth.render.backend import (
    BACKENDS,
    DEBIAN_FIX,
    GLBackendError,
    check_backend_name,
    check_threads,
    choose_backend,
    driver_threads,
    refuse_late_threads,
    resolve_backend,
)
from synth.render.context import open_context
from synth.render.meshes import as_meshes, check_depth_range
from synth.render.labels import LabelPass
from synth.render.passes import GLScene, Passes
from synth.render.sky import over_sky

if TYPE_CHECKING:
    from synth.camera.rig import StereoRig

__all__ = ["GLBackendError", "Renderer", "ViewRender", "ViewLabels", "BACKENDS", "resolve_backend"]

#: Entries of an uploaded scene's metadata that only drawing reads (not the pair's metadata).
_DRAWING_ONLY = frozenset({"background", "sky"})


@dataclass(frozen=True)
class ViewRender:
    """One rendered view.

    Attributes
    ----------
    color : (H, W, 3) uint8 array
        RGB image, row 0 at the top.
    depth : (H, W) float32 array
        Camera-space depth ``Z`` (metres, along the optical axis) of the
        surface seen through each pixel centre; ``inf`` where there is none.
    highlight : (H, W) float32 array or None
        Scenes with a specular material only: how many grey levels (of 255, the largest
        channel) the specular term adds at each pixel centre (see
        :data:`synth.render.lighting.HIGHLIGHT_LEVELS`); None for other scenes.
    """

    color: np.ndarray
    depth: np.ndarray
    highlight: np.ndarray | None = None


@dataclass(frozen=True)
class ViewLabels:
    """The labels pass of one view (:meth:`Renderer.render_labels`).

    Attributes
    ----------
    normals : (H, W, 3) float32 array
        Unit surface normal (camera axes: x right, y down, z forward) at each pixel centre,
        turned toward the camera; the mesh's vertex normals interpolated across each triangle.
        ``0`` where there is no surface.
    instance : (H, W) uint32 array
        1 + the index of the object seen (scene order); 0 where there is none.
    """

    normals: np.ndarray
    instance: np.ndarray


# ---------------------------------------------------------------------------- geometry
def _projection(rig: StereoRig) -> np.ndarray:
    """OpenGL projection of the OpenCV-convention pinhole (pixel centres at integers)."""
    w, h, n, f = rig.width, rig.height, rig.near, rig.far
    P = np.zeros((4, 4))
    P[0, 0] = 2.0 * rig.fx / w
    P[0, 2] = 1.0 - 2.0 * (rig.cx + 0.5) / w
    P[1, 1] = 2.0 * rig.fy / h
    P[1, 2] = 2.0 * (rig.cy + 0.5) / h - 1.0
    P[2, 2] = -(f + n) / (f - n)
    P[2, 3] = -2.0 * f * n / (f - n)
    P[3, 2] = -1.0
    return P


def _camera_pose(rig: StereoRig, eye: str) -> np.ndarray:
    """Pose (camera -> world) of the GL camera: OpenCV axes flipped to OpenGL's."""
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    if eye == "right":
        pose[0, 3] = rig.baseline
    return pose


# ---------------------------------------------------------------------------- Renderer
class Renderer:
    """An offscreen OpenGL context that renders views with exact depth.

    One GL context lives as long as the renderer and is reused by every render.
    Use it as a context manager (or call :meth:`close`).

    Parameters
    ----------
    width, height : int
        Initial framebuffer size in pixels. A rig of another size may be
        rendered: the framebuffers are reallocated to it (cheap, but keep one
        size per renderer in a loop).
    backend : {"auto", "egl", "osmesa"}
        ``"auto"`` tries EGL, then OSMesa. PyOpenGL binds one platform per
        process at its first import, so all renderers of a process share it.
    probe : bool
        Probe the backend in a subprocess first (default). ``False`` skips the
        probe for a named backend that :func:`resolve_backend` already found
        working on this machine (worker processes of a pool).
    threads : int, optional
        Rasterizer threads of Mesa's llvmpipe (``LP_NUM_THREADS``); ``None``
        leaves its default (one per core, or the environment's value). ``0``
        rasterizes in the calling thread: the least CPU per image (measured
        here: ~15 % less than with worker threads), the right choice when
        several processes already share the cores. Images do not depend on it.
        The driver reads it once per process, at the first renderer: a later
        renderer asking for another value raises ``ValueError``.

    Raises
    ------
    GLBackendError
        If no requested backend starts (the message names each backend tried,
        its error and the fix: a pip or a Debian package).

    Examples
    --------
    >>> import trimesh
    >>> from synth.camera.rig import StereoRig
    >>> quad = trimesh.Trimesh([[-1, -1, 2], [1, -1, 2], [1, 1, 2], [-1, 1, 2]],
    ...                        [[0, 1, 2], [0, 2, 3]], process=False)
    >>> rig = StereoRig.default(32, 24)
    >>> with Renderer(32, 24) as r:
    ...     view = r.render_view([quad], rig, eye="left")
    >>> float(view.depth[12, 16])
    2.0
    """

    def __init__(self, width: int, height: int, *, backend: str = "auto",
                 probe: bool = True, threads: int | None = None) -> None:
        for name, value in (("width", width), ("height", height)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
                raise ValueError(f"{name} must be a positive int, got {value!r}")
        check_backend_name(backend)
        check_threads(threads)
        refuse_late_threads(threads)
        self.width, self.height = int(width), int(height)
        self._closed = True
        self._held: dict[int, tuple[Any, GLScene]] = {}
        self._labels: LabelPass | None = None  # made at the first render_labels
        self._timings: dict[str, float] | None = None  # set inside a pass_timings block
        self.backend = choose_backend(backend, probe=probe)
        try:
            with driver_threads(threads):
                self._context = open_context(self.backend)
            from OpenGL import GL

            GL.glPixelStorei(GL.GL_PACK_ALIGNMENT, 1)
            GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 1)
            self._passes = Passes(self.width, self.height)
            self.gl_renderer = GL.glGetString(GL.GL_RENDERER).decode()
            self.gl_version = GL.glGetString(GL.GL_VERSION).decode()
        except GLBackendError as exc:
            raise GLBackendError(f"the {self.backend} backend failed to start: {exc.problem}",
                                 fix=exc.fix) from exc
        except ParameterError as exc:  # a size above the context's limits (GLLimits)
            self._context.destroy()
            raise ParameterError(f"{exc} (the {self.backend} backend)") from None
        except Exception as exc:
            raise GLBackendError(
                f"the {self.backend} backend failed to start in this process: "
                f"{type(exc).__name__}: {exc}", fix=DEBIAN_FIX[self.backend]
            ) from exc
        self._closed = False

    # -------------------------------------------------------------- lifetime
    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Free every GL resource and the context (idempotent)."""
        if self._closed:
            return
        self._context.make_current()
        for _, up in list(self._held.values()):
            self._passes.release(up)
        self._held.clear()
        if self._labels is not None:
            self._labels.delete()
        self._passes.delete()
        self._context.destroy()  # only ours: the EGL display, shared by all, stays initialised
        self._closed = True

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("this Renderer is closed; open a new one (use it as a `with` block)")

    # -------------------------------------------------------------- profiling
    @contextmanager
    def pass_timings(self, timings: dict[str, float]) -> Iterator[dict[str, float]]:
        """Inside the block, add each pass's seconds to ``timings`` (for benchmarks).

        Keys: ``meshes`` (scene to vertex arrays and texture synthesis, no GL), ``upload``
        (buffers, textures and their mipmaps), ``colour`` (the multisampled colour pass, its
        resolve and read-back), ``depth`` (the float depth pass and read-back), ``highlight``
        (specular scenes); wall time under the key, CPU time of the process (all threads)
        under ``key + "_cpu"``. Each timed pass waits for the GL to finish (``glFinish``)
        before and after it, so work the driver would defer is charged to its own pass; the
        images do not change. Yields ``timings``.

        Examples
        --------
        >>> from synth.camera.rig import StereoRig
        >>> from scenes import get_preset
        >>> t = {}
        >>> with Renderer(32, 24) as r, r.pass_timings(t):
        ...     _ = r.render_view(get_preset("boxes"), StereoRig.default(32, 24), eye="left")
        >>> sorted(k for k in t if not k.endswith("_cpu"))
        ['colour', 'depth', 'meshes', 'upload']
        """
        before, self._timings = self._timings, timings
        try:
            yield timings
        finally:
            self._timings = before

    @contextmanager
    def _timed(self, name: str, *, gl: bool = True) -> Iterator[None]:
        timings = self._timings
        if timings is None:
            yield
            return
        from OpenGL import GL

        finish = GL.glFinish if gl else (lambda: None)
        finish()
        t0, c0 = time.perf_counter(), time.process_time()
        yield
        finish()
        timings[name] = timings.get(name, 0.0) + time.perf_counter() - t0
        timings[f"{name}_cpu"] = timings.get(f"{name}_cpu", 0.0) + time.process_time() - c0

    # -------------------------------------------------------------- uploads
    @contextmanager
    def uploaded(self, scene: Any) -> Iterator[dict]:
        """Keep ``scene`` on the GPU for the ``with`` block; release it after.

        Renders of the same scene object inside the block reuse its meshes and
        textures (``render_pair`` renders left and right this way). Yields the
        scene's metadata (name, seed).
        """
        self._check_open()
        key = id(scene)
        if key in self._held:
            yield {k: v for k, v in self._held[key][1].meta.items() if k not in _DRAWING_ONLY}
            return
        with self._timed("meshes", gl=False):
            meshes, background, meta = as_meshes(scene)
        lighting = None
        if getattr(scene, "is_lit", None) is not None and scene.is_lit():
            from synth.render.lighting import scene_lights

            lighting = scene_lights(scene)
            meta = {**meta, "specular": scene.has_specular()}
        self._context.make_current()
        with self._timed("upload"):
            up = self._passes.upload(meshes, {**meta, "background": background,
                                              "sky": getattr(scene, "sky", None)},
                                     lighting=lighting)
        self._held[key] = (scene, up)  # keeps `scene` alive so its id is not reused
        try:
            yield {k: v for k, v in up.meta.items() if k not in _DRAWING_ONLY}
        finally:
            del self._held[key]
            self._context.make_current()
            self._passes.release(up)

    # -------------------------------------------------------------- render
    def render_view(self, scene: Any, rig: StereoRig, *, eye: str) -> ViewRender:
        """Render one view of ``scene`` through ``rig``.

        Parameters
        ----------
        scene : scenes.SceneSpec or sequence of trimesh.Trimesh
            Meshes in world coordinates (= left camera frame, OpenCV axes).
        rig : StereoRig
            Intrinsics, baseline and image size of the view.
        eye : {"left", "right"}
            The right camera sits at ``(rig.baseline, 0, 0)``.

        Returns
        -------
        ViewRender
            ``color`` (H, W, 3) uint8 and ``depth`` (H, W) float32 ``Z`` with
            ``inf`` where the pixel centre's ray hits nothing.

        Raises
        ------
        ValueError
            If an object lies behind the camera or outside ``[near, far]``.
        """
        with self._view(scene, rig, eye) as up:
            return self._render(up, rig, eye)

    @contextmanager
    def _view(self, scene: Any, rig: StereoRig, eye: str) -> Iterator[GLScene]:
        """The checked arguments of one view: ``scene`` uploaded, its depth range checked, the
        context current and the framebuffers of the rig's size."""
        from synth.camera.rig import StereoRig

        self._check_open()
        if not isinstance(rig, StereoRig):
            raise TypeError(f"rig must be a StereoRig, got {type(rig).__name__}")
        if eye not in ("left", "right"):
            raise ValueError(f"eye must be 'left' or 'right', got {eye!r}")
        with self.uploaded(scene):
            up = self._held[id(scene)][1]
            check_depth_range(up.meshes, rig)
            self._context.make_current()
            if (rig.width, rig.height) != (self.width, self.height):
                self.width, self.height = rig.width, rig.height
                self._passes.resize(rig.width, rig.height)
            yield up

    def render_labels(self, scene: Any, rig: StereoRig, *, eye: str) -> ViewLabels:
        """Render the labels of one view: surface normals and instance ids (a ground-truth pass
        with the depth pass's visibility; the colour and depth passes are unchanged by it)."""
        with self._view(scene, rig, eye) as up:
            pose = _camera_pose(rig, eye)
            pv = (_projection(rig) @ np.linalg.inv(pose)).astype(np.float32)
            if self._labels is None:
                self._labels = LabelPass(self.width, self.height)
            elif (self._labels.w, self._labels.h) != (self.width, self.height):
                self._labels.resize(self.width, self.height)
            Passes.common_state()
            normals, instance = self._labels.render(up, pv, rig.far, pose[:3, 3])
            return ViewLabels(normals=normals, instance=instance)

    def _render(self, up: GLScene, rig: StereoRig, eye: str) -> ViewRender:
        pose = _camera_pose(rig, eye)
        pv = (_projection(rig) @ np.linalg.inv(pose)).astype(np.float32)
        position = pose[:3, 3]
        sky = up.meta.get("sky")
        with self._timed("colour"):
            if sky is None:
                color = self._passes.color(up, pv, up.meta["background"], eye=position)
            else:  # transparent where no surface, then over the sky at infinity
                color = over_sky(self._passes.color_rgba(up, pv, (0.0, 0.0, 0.0, 0.0),
                                                         eye=position), sky, rig)
        with self._timed("depth"):
            depth = self._passes.depth(up, pv, rig.far)
        highlight = None
        if up.meta.get("specular"):
            with self._timed("highlight"):
                highlight = self._passes.highlight(up, pv, position)
        return ViewRender(color=color, depth=depth, highlight=highlight)
