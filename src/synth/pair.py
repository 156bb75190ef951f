"""Render a labelled stereo pair: images, exact disparities, occlusion mask.

Disparities are ``fx * baseline / Z`` (float64, then float32) of the depth the
renderer reads at each pixel centre; ``inf`` where no surface, and 0 (exact) where a scene's sky
at infinity shows (:mod:`scenes.sky`; ``sky_left`` marks it). The left mask
follows ``docs/conventions.md``: 255 visible in both views, 128 occluded in
the right view or projecting outside it, 0 no ground truth.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.metadata
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np
from numba import njit

from stereoforge.validation import check_real, check_type
from synth.render.lighting import HIGHLIGHT_LEVELS
from synth.render.meshes import DISPLAY_GAMMA
from synth.camera.imperfect import real_views
from synth.render.renderer import Renderer
from synth.camera.rig import StereoRig

__all__ = [
    "StereoPair",
    "render_pair",
    "expose",
    "occlusion_mask",
    "ground_truth_from_depth",
    "MASK_VISIBLE",
    "MASK_OCCLUDED",
    "MASK_INVALID",
    "LERP_TOL",
    "EDGE_TOL",
]

MASK_VISIBLE, MASK_OCCLUDED, MASK_INVALID = 255, 128, 0
#: |d_left - d_right interpolated at x - d_left| (px) below which a pixel is visible.
LERP_TOL = 0.01
#: ... or |d_left - a right sample bracketing x - d_left| (px) below which it is visible.
EDGE_TOL = 0.5


@dataclass(frozen=True)
class StereoPair:
    """A rendered rectified pair with exact ground truth (arrays are read-only).

    Attributes
    ----------
    left, right : (H, W, 3) uint8 array
        RGB images.
    disp_left, disp_right : (H, W) float32 array
        Disparity in pixels of each view (left ``x`` matches right ``x - d``,
        right ``x`` matches left ``x + d``); ``inf`` where no surface, 0 where the scene's sky
        shows (``sky_left``).
    depth_left : (H, W) float32 array
        Depth ``Z`` (metres) of the left view; ``inf`` where no surface.
    mask_left : (H, W) uint8 array
        255 visible in both views, 128 occluded in (or outside) the right view,
        0 no ground truth.
    rig : StereoRig
    meta : Mapping
        ``scene``, ``seed``, ``backend``, ``renderer`` (GL_RENDERER),
        ``gl_version``, ``mask_tolerances`` and package ``versions``; for lit scenes
        ``specular`` (whether an object is specular), with the variants ``exposure_variant``
        (the factor) and ``lighting_variant`` (the light and lamps of ``im1L``).
    highlight_left, highlight_right : (H, W) uint8 array or None
        Scenes with a specular material and an ideal rig (no camera ``errors``) only: 255 where the specular term raises the displayed
        value of some channel at the pixel centre by at least
        :data:`synth.render.lighting.HIGHLIGHT_LEVELS` grey levels, else 0.
    right_exposure : (H, W, 3) uint8 array or None
        The right view at another exposure (Middlebury's ``im1E``; see :func:`expose`).
    right_lighting : (H, W, 3) uint8 array or None
        The right view rendered again under another light set (Middlebury's ``im1L``).
    sky_left : (H, W) uint8 array or None
        Scenes with a sky only: 255 where the left view's pixel centre sees the sky (depth
        ``inf``, disparity 0), else 0 (``mask0sky.png``).
    flow_left : (H, W, 2) float32 array or None
        Only for a rig with camera ``errors``: the exact correspondence of the real images,
        left ``(x, y)`` -> right ``(x + u, y + v)``; NaN where no surface, occluded or outside
        the right image. ``left`` and ``right`` are then the real cameras' images while the
        disparities, depth and mask stay the ideal rig's (``docs/formats.md``, *flow0.flo*).
    """

    left: np.ndarray
    right: np.ndarray
    disp_left: np.ndarray
    disp_right: np.ndarray
    depth_left: np.ndarray
    mask_left: np.ndarray
    rig: StereoRig
    meta: Mapping[str, Any]
    flow_left: np.ndarray | None = None
    highlight_left: np.ndarray | None = None
    highlight_right: np.ndarray | None = None
    right_exposure: np.ndarray | None = None
    right_lighting: np.ndarray | None = None
    sky_left: np.ndarray | None = None


def occlusion_mask(
    disp_left: np.ndarray,
    disp_right: np.ndarray,
    *,
    lerp_tol: float = LERP_TOL,
    edge_tol: float = EDGE_TOL,
) -> np.ndarray:
    """Left-view visibility from the two exact disparity maps.

    A left pixel ``x`` with finite ``d`` projects to ``xr = x - d`` in the
    right view. It is occluded (128) if ``xr < -0.5`` (outside the right image)
    or if the right view sees a different surface there; it is visible (255)
    if ``|d - lerp| <= lerp_tol``, where ``lerp`` is the right disparity
    linearly interpolated at ``xr`` (exact on planes, where disparity is affine
    in ``x``), or if ``|d - s| <= edge_tol`` for one of the (at most two) right
    samples ``s`` bracketing ``xr``: this keeps smooth surfaces with slopes
    below 1 px/px visible where the interpolation straddles a depth
    discontinuity or crease. Within a pixel of an occlusion boundary the
    samples cannot tell which surface covers ``xr``: the result there is
    a convention.

    Parameters
    ----------
    disp_left, disp_right : (H, W) float array
        Disparities of the left and right views, ``inf`` where no surface.
    lerp_tol, edge_tol : float
        Tolerances in pixels (see above).

    Returns
    -------
    mask : (H, W) uint8 array
        255 visible, 128 occluded, 0 where ``disp_left`` is not finite.

    Examples
    --------
    >>> dl = np.array([[np.inf, 2.0, 1.0, 3.0]])
    >>> dr = np.array([[1.0, 1.0, 3.0, 3.0]])
    >>> occlusion_mask(dl, dr).tolist()
    [[0, 128, 255, 128]]
    """
    dl = np.asarray(disp_left, dtype=np.float64)
    dr = np.asarray(disp_right, dtype=np.float64)
    if dl.ndim != 2 or dl.shape != dr.shape:
        raise ValueError(
            f"disp_left and disp_right must be (H, W) arrays of one shape, got {dl.shape} "
            f"and {dr.shape}"
        )
    mask = np.empty(dl.shape, dtype=np.uint8)
    _mask_kernel(np.ascontiguousarray(dl), np.ascontiguousarray(dr), float(lerp_tol),
                 float(edge_tol), mask)
    return mask


@njit(cache=True, nogil=True, inline="always")
def _mask_code(d: float, j: int, dr_row: np.ndarray, lerp_tol: float,
               edge_tol: float) -> int:  # pragma: no cover - compiled
    """The code of left pixel ``j`` of disparity ``d`` against its row of right disparities."""
    if not np.isfinite(d):
        return MASK_INVALID
    xr = j - d
    if not xr >= -0.5:  # outside the right image (d >= 0: never beyond its right edge)
        return MASK_OCCLUDED
    w = dr_row.shape[0]
    x0 = np.floor(xr)
    t = xr - x0
    i0 = int(x0)
    a = dr_row[max(i0, 0)]
    b = dr_row[min(i0 + 1, w - 1)]
    # NaN (inf - inf where the right view sees nothing) fails every comparison
    ok = (abs(d - (a + t * (b - a))) <= lerp_tol or abs(d - a) <= edge_tol
          or (t > 0 and abs(d - b) <= edge_tol))  # b brackets xr only if t > 0
    return MASK_VISIBLE if ok else MASK_OCCLUDED


@njit(cache=True, nogil=True)
def _mask_kernel(dl: np.ndarray, dr: np.ndarray, lerp_tol: float, edge_tol: float,
                 mask: np.ndarray) -> None:  # pragma: no cover - compiled
    """Body of :func:`occlusion_mask`: float64 disparities in, codes written to ``mask``."""
    h, w = dl.shape
    for i in range(h):
        for j in range(w):
            mask[i, j] = _mask_code(dl[i, j], j, dr[i], lerp_tol, edge_tol)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _disparity(fb: float, z: np.float32) -> float:  # pragma: no cover - compiled
    """:meth:`StereoRig.disparity_from_depth` of one depth: ``fb / z`` in float64, ``inf``
    where that is not > 0 (no surface: ``z = inf``; NaN, ``z <= 0``)."""
    d = fb / np.float64(z)
    return d if d > 0 else np.inf


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _view_disparity(fb: float, z: np.float32, sky: bool) -> float:  # pragma: no cover
    """:func:`_disparity`, and 0 where the pixel sees nothing but the sky (``z = inf``)."""
    if sky and z == np.inf:
        return 0.0
    return _disparity(fb, z)


@njit(cache=True, nogil=True, error_model="numpy")
def _ground_truth_kernel(zl: np.ndarray, zr: np.ndarray, fb: float, sky: bool, lerp_tol: float,
                         edge_tol: float, disp_left: np.ndarray, disp_right: np.ndarray,
                         mask: np.ndarray) -> None:  # pragma: no cover - compiled
    """Both views' float64 disparities from their depths (stored as float32) and the left
    view's :func:`occlusion_mask` of them, in one pass over the rows."""
    h, w = zl.shape
    dr_row = np.empty(w, np.float64)
    for i in range(h):
        for j in range(w):
            dr_row[j] = _view_disparity(fb, zr[i, j], sky)
            disp_right[i, j] = np.float32(dr_row[j])
        for j in range(w):
            d = _view_disparity(fb, zl[i, j], sky)
            disp_left[i, j] = np.float32(d)
            mask[i, j] = _mask_code(d, j, dr_row, lerp_tol, edge_tol)


def ground_truth_from_depth(rig: StereoRig, depth_left: np.ndarray, depth_right: np.ndarray,
                            *, sky: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ground truth of a pair from its two depth maps, in one pass.

    Parameters
    ----------
    rig : StereoRig
    depth_left, depth_right : (H, W) float32 array
        Camera-space ``Z`` of each view (``inf``: no surface).
    sky : bool
        The scene has a sky at infinity: ``Z = inf`` is then the sky, disparity 0 (a finite
        ground truth, masked like any other), not "no ground truth".

    Returns
    -------
    disp_left, disp_right : (H, W) float32 array
        ``rig.disparity_from_depth`` of each map (computed in float64), stored as float32.
    mask : (H, W) uint8 array
        :func:`occlusion_mask` of the float64 disparities.

    Examples
    --------
    >>> rig = StereoRig.default(4, 1, baseline=0.1)  # fx = 3.75: fx * baseline = 0.375
    >>> z = np.array([[np.inf, 0.375, 0.375, 0.375]], np.float32)
    >>> dl, dr, mask = ground_truth_from_depth(rig, z, z)
    >>> dl.tolist(), mask.tolist()
    ([[inf, 1.0, 1.0, 1.0]], [[0, 128, 255, 255]])
    >>> dl, dr, mask = ground_truth_from_depth(rig, z, z, sky=True)
    >>> dl.tolist(), mask.tolist()
    ([[0.0, 1.0, 1.0, 1.0]], [[255, 128, 255, 255]])
    """
    shape = depth_left.shape
    disp_left, disp_right = np.empty(shape, np.float32), np.empty(shape, np.float32)
    mask = np.empty(shape, np.uint8)
    _ground_truth_kernel(np.ascontiguousarray(depth_left, dtype=np.float32),
                         np.ascontiguousarray(depth_right, dtype=np.float32),
                         float(rig.fx * rig.baseline), bool(sky), float(LERP_TOL),
                         float(EDGE_TOL),
                         disp_left, disp_right, mask)
    return disp_left, disp_right, mask


@functools.cache
def _versions() -> dict[str, str]:
    out = {}
    for dist in ("stereoforge", "numpy", "trimesh", "PyOpenGL"):
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:  # pragma: no cover
            out[dist] = "unknown"
    return out


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def expose(image: np.ndarray, factor: float) -> np.ndarray:
    """An 8-bit display-encoded image at another exposure, changed in linear light.

    ``out = round(255 * min(1, (image / 255) ** g * factor) ** (1 / g))`` with the display
    gamma ``g`` = 2.2 of the renderer: the exposure time (or gain) scales linear radiance by
    ``factor`` before the display gamma; saturated values clip at 255. ``factor`` = 2 is one
    stop brighter.

    Examples
    --------
    >>> expose(np.array([[0, 128, 255]], np.uint8), 0.5).tolist()
    [[0, 93, 186]]
    """
    factor = check_real(factor, "exposure", lo=0.0, lo_open=True, hi=16.0,
                        fix="a linear factor such as 0.5 (one stop darker)")
    linear = (np.asarray(image, dtype=np.float64) / 255.0) ** DISPLAY_GAMMA * factor
    return np.rint(255.0 * np.minimum(linear, 1.0) ** (1.0 / DISPLAY_GAMMA)).astype(np.uint8)


def _highlight(view: Any) -> np.ndarray | None:
    if view.highlight is None:
        return None
    return _readonly(np.where(view.highlight >= HIGHLIGHT_LEVELS, 255, 0).astype(np.uint8))


def render_pair(
    scene: Any,
    rig: StereoRig,
    *,
    renderer: Renderer | None = None,
    backend: str = "auto",
    exposure: float | None = None,
    lighting: Any = None,
) -> StereoPair:
    """Render the left and right views of ``scene`` with exact ground truth.

    Parameters
    ----------
    scene : scenes.SceneSpec or sequence of trimesh.Trimesh
        Geometry in the left camera's frame (OpenCV axes, metres).
    rig : StereoRig
    renderer : Renderer, optional
        An open renderer of the rig's size, reused across pairs; if omitted a
        renderer is opened (with ``backend``) for this call and closed after.
    backend : {"auto", "egl", "osmesa"}
        Only used when ``renderer`` is None.
    exposure : float, optional
        Also make ``right_exposure``: the right view with its linear radiance scaled by this
        factor (:func:`expose`).
    lighting : scenes.SceneSpec, optional
        Also render ``right_lighting``: the right view of this scene, which must have the same
        objects as ``scene`` (typically ``dataclasses.replace(scene, light=..., lamps=...)``).

    Returns
    -------
    StereoPair

    Examples
    --------
    >>> import scenes
    >>> rig = StereoRig.default(64, 48)
    >>> pair = render_pair(scenes.get_preset("fronto_plane"), rig)
    >>> float(pair.disp_left[24, 32])  # 60 px * 0.1 m / 2 m
    3.0
    """
    if not isinstance(rig, StereoRig):
        raise TypeError(f"rig must be a StereoRig, got {type(rig).__name__}")
    if lighting is not None:
        check_type(lighting, "lighting", type(scene), expected="a SceneSpec like the scene's")
        if lighting.objects != scene.objects:
            raise ValueError("lighting: expected the scene with only its lights changed, got "
                             "other objects; use dataclasses.replace(scene, light=..., lamps=...)")
    if lighting is not None and rig.errors is not None:
        raise ValueError("lighting: the im1L variant is rendered by the ideal right camera; it "
                         "cannot be combined with camera errors (rig.errors); drop one of them")
    if renderer is None:
        with Renderer(rig.width, rig.height, backend=backend) as own:
            return render_pair(scene, rig, renderer=own, exposure=exposure, lighting=lighting)
    if not isinstance(renderer, Renderer):
        raise TypeError(f"renderer must be a synth.render.Renderer, got {type(renderer).__name__}")
    ideal = rig.ideal
    with renderer.uploaded(scene) as scene_meta:
        left = renderer.render_view(scene, ideal, eye="left")
        right = renderer.render_view(scene, ideal, eye="right")
        real = None if rig.errors is None else real_views(
            scene, rig, renderer=renderer, ideal=(left.color, right.color))
    relit = None
    if lighting is not None:
        relit = _readonly(renderer.render_view(lighting, ideal, eye="right").color)
    sky = getattr(scene, "sky", None) is not None
    d_left, d_right, mask = ground_truth_from_depth(rig, left.depth, right.depth, sky=sky)
    meta = {
        **scene_meta,
        "backend": renderer.backend,
        "renderer": renderer.gl_renderer,
        "gl_version": renderer.gl_version,
        "mask_tolerances": {"lerp_tol": LERP_TOL, "edge_tol": EDGE_TOL},
        "versions": dict(_versions()),
    }
    if real is not None:
        meta["camera_errors"] = rig.errors.to_dict()
    if exposure is not None:  # recorded only when asked for: other pairs keep their scene.json
        meta["exposure_variant"] = float(exposure)
    if lighting is not None:
        meta["lighting_variant"] = {"light": dataclasses.asdict(lighting.light),
                                    "lamps": [dataclasses.asdict(lamp) for lamp in lighting.lamps]}
    return StereoPair(
        left=_readonly(left.color if real is None else real.left),
        right=_readonly(right.color if real is None else real.right),
        disp_left=_readonly(d_left),
        disp_right=_readonly(d_right),
        depth_left=_readonly(left.depth),
        mask_left=_readonly(mask),
        rig=rig,
        meta=MappingProxyType(meta),
        flow_left=None if real is None else _readonly(real.flow),
        # the highlight masks are the ideal cameras': none for a rig with camera errors
        highlight_left=_highlight(left) if real is None else None,
        highlight_right=_highlight(right) if real is None else None,
        right_exposure=None if exposure is None else _readonly(
            expose(right.color if real is None else real.right, exposure)),
        right_lighting=relit,
        sky_left=_readonly(np.where(np.isinf(left.depth), 255, 0).astype(np.uint8)) if sky
        else None,
    )
