"""Texture frequency, contrast and edge density under control.

Texture frequency is given in **cycles per pixel** at each object's reference depth ``Z_ref``
(the depth of its centre, ``pose.translation[2]``) and converted to cycles per metre on the
surface as ``f_m = f_px * fx / Z_ref``. Edge density ``rho`` is the fraction of Canny edge pixels
in the rendered left image, measured with the project's one Canny setting,
:func:`matcher.edges.canny_edges` with its defaults (Gaussian ``sigma`` =
:data:`~matcher.edges.CANNY_SIGMA`, hysteresis thresholds
:data:`~matcher.edges.CANNY_LOW`/:data:`~matcher.edges.CANNY_HIGH` of the full range) on the
BT.601 grey image.

:func:`match_edge_density` closes the loop: it searches the texture frequency (log scale, over
``[F_MIN_PX, F_MAX_PX]``, contrast fixed) so that the rendered left view has the requested
``rho``. ``rho`` grows with frequency on that interval for noise, checker and stripe textures
(about ``2.6 * f_px`` up to ``rho ~ 0.4`` at 0.25 cycles/px); beyond it the renderer's
antialiasing blurs the texture away, so the interval stops there. Each probe renders the left
view only (texture synthesis + upload + one colour and one depth pass + Canny); a search takes
2-6 probes (see ``docs/datasets.md`` for the measured cost).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from matcher.edges import CANNY_HIGH, CANNY_LOW, CANNY_SIGMA, canny_edges
from scenes import SceneSpec

__all__ = [
    "CANNY_SETTINGS",
    "F_MIN_PX",
    "F_MAX_PX",
    "SEARCH_TOL",
    "EdgeSearch",
    "edge_density",
    "frequency_per_metre",
    "retexture",
    "match_edge_density",
]

#: The Canny settings of every edge density in stereoforge (those of :mod:`matcher.edges`).
CANNY_SETTINGS = {"sigma": CANNY_SIGMA, "low": CANNY_LOW, "high": CANNY_HIGH}
#: Frequency interval (cycles per pixel) searched by :func:`match_edge_density`.
F_MIN_PX, F_MAX_PX = 0.004, 0.25
#: The search stops once the measured density is this close to the target.
SEARCH_TOL = 0.004
_MAX_PROBES = 12
_SLOPE = 2.6  # rho ~ _SLOPE * f_px on noise textures: the first guess


def edge_density(image: np.ndarray) -> float:
    """Fraction of Canny edge pixels of an image (the project's Canny settings).

    Parameters
    ----------
    image : (H, W) or (H, W, 3) uint8 array

    Returns
    -------
    float in [0, 1]

    Examples
    --------
    >>> img = np.zeros((16, 16), np.uint8)
    >>> img[:, 8:] = 200
    >>> edge_density(img) == 14 / 256  # one edge column (the outermost rows are never marked)
    True
    """
    return float(np.count_nonzero(canny_edges(image, **CANNY_SETTINGS))) / float(
        image.shape[0] * image.shape[1])


def frequency_per_metre(frequency_px: float, *, fx: float, depth: float) -> float:
    """Surface frequency in cycles per metre of ``frequency_px`` cycles per pixel at ``depth``.

    A fronto-parallel surface at depth ``Z`` is imaged at ``fx / Z`` pixels per metre, so
    ``f_m = f_px * fx / Z``.

    Examples
    --------
    >>> frequency_per_metre(0.125, fx=600.0, depth=2.0)
    37.5
    """
    for name, value in (("frequency_px", frequency_px), ("fx", fx), ("depth", depth)):
        if not (isinstance(value, (int, float, np.integer, np.floating)) and math.isfinite(value)
                and value > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(frequency_px) * float(fx) / float(depth)


def retexture(scene: SceneSpec, *, fx: float, frequency_px: float | None = None,
              contrast: float | None = None, kind: str | None = None) -> SceneSpec:
    """``scene`` with every object's texture frequency, contrast and/or kind replaced.

    Parameters
    ----------
    scene : SceneSpec
    fx : float
        Focal length of the rig (pixels).
    frequency_px : float, optional
        Cycles per pixel at each object's centre depth (``f_m = f_px * fx / Z_ref``); None
        keeps the frequencies.
    contrast : float, optional
        New contrast in [0, 1]; None keeps it.
    kind : str, optional
        New texture kind (``scenes.spec.TEXTURE_KINDS``); None keeps it.

    Returns
    -------
    SceneSpec

    Examples
    --------
    >>> import scenes
    >>> s = retexture(scenes.get_preset("fronto_plane"), fx=600.0, frequency_px=0.1)
    >>> s.objects[0].texture.frequency  # 0.1 * 600 / 2 m
    30.0
    """
    if not isinstance(scene, SceneSpec):
        raise TypeError(f"scene must be a SceneSpec, got {type(scene).__name__}")
    objects = []
    for obj in scene.objects:
        changes: dict[str, Any] = {}
        if frequency_px is not None:
            z = obj.pose.translation[2]
            if z <= 0:
                raise ValueError(f"object {obj.name or obj.kind!r} has its centre at z={z} <= 0; "
                                 "a reference depth needs an object in front of the camera")
            changes["frequency"] = frequency_per_metre(frequency_px, fx=fx, depth=z)
        if contrast is not None:
            changes["contrast"] = contrast
        if kind is not None:
            changes["kind"] = kind
        texture = dataclasses.replace(obj.texture, **changes) if changes else obj.texture
        objects.append(dataclasses.replace(obj, texture=texture))
    return dataclasses.replace(scene, objects=tuple(objects))


@dataclass(frozen=True)
class EdgeSearch:
    """Result of :func:`match_edge_density`.

    Attributes
    ----------
    scene : SceneSpec
        The retextured scene whose left view has ``edge_density``.
    frequency_px : float
        Texture frequency chosen, cycles per pixel at each object's depth.
    edge_density : float
        Measured edge density of the left view of ``scene``.
    target : float
    probes : int
        Left views rendered.
    converged : bool
        ``|edge_density - target| <= SEARCH_TOL``; False when the target is out of reach (below
        the density of the untextured geometry's edges or above the densest texture).
    left : (H, W, 3) uint8 array
        The rendered left view (a copy) of ``scene`` whose density is ``edge_density`` (read-only), so
        that a caller rendering ``scene`` again can reuse the measurement when the images are
        equal instead of running Canny again.
    """

    scene: SceneSpec
    frequency_px: float
    edge_density: float
    target: float
    probes: int
    converged: bool
    left: np.ndarray = dataclasses.field(repr=False, compare=False)


def match_edge_density(
    scene: SceneSpec,
    rig: Any,
    target: float,
    *,
    renderer: Any = None,
    render_left: Callable[[SceneSpec], np.ndarray] | None = None,
    tol: float = SEARCH_TOL,
) -> EdgeSearch:
    """Find the texture frequency giving the left view of ``scene`` the edge density ``target``.

    A safeguarded secant search on ``log f_px`` over ``[F_MIN_PX, F_MAX_PX]``: the first probe is
    ``target / 2.6``; each probe brackets the root (``rho`` grows with frequency there) and the
    next is the secant point of the bracket, kept at least 10 % inside it (bisection when only one
    side is known). It stops at ``|rho - target| <= tol``, after 12 probes, or when the bracket is
    narrower than 0.1 % in frequency, and returns the best probe. Deterministic: the same scene,
    rig and target give the same result.

    Parameters
    ----------
    scene : SceneSpec
        Scene whose textures (kind, contrast, seeds) are kept; only frequencies change.
    rig : StereoRig
    target : float
        Requested edge density in (0, 1); reliably reached in [0.02, 0.30] at 640 x 480.
    renderer : synth.render.Renderer, optional
        Open renderer used for the probes (one is needed unless ``render_left`` is given).
    render_left : callable, optional
        ``render_left(scene) -> (H, W, 3) uint8`` left image, instead of ``renderer``.
    tol : float
        Stopping tolerance on ``rho``.

    Returns
    -------
    EdgeSearch

    Examples
    --------
    >>> import scenes
    >>> def fake(s):  # a stand-in "renderer": vertical stripes at the texture frequency
    ...     f = s.objects[0].texture.frequency * 2.0 / 60.0  # cycles per pixel
    ...     x = np.arange(64)
    ...     return np.repeat(((np.sin(2 * np.pi * f * x) > 0) * 200).astype(np.uint8)[None],
    ...                      48, axis=0)
    >>> from synth.camera.rig import StereoRig
    >>> r = match_edge_density(scenes.get_preset("fronto_plane"), StereoRig.default(64, 48), 0.1,
    ...                        render_left=fake)
    >>> abs(r.edge_density - 0.1) <= 0.02
    True
    """
    if isinstance(target, bool) or not isinstance(target, (int, float, np.floating)) or not (
            math.isfinite(target) and 0 < target < 1):
        raise ValueError(f"target edge density must be in (0, 1), got {target!r}")
    if render_left is None:
        if renderer is None:
            raise ValueError("match_edge_density needs a renderer (an open synth.render.Renderer)"
                             " or a render_left function")

        def render_left(s: SceneSpec) -> np.ndarray:
            return renderer.render_view(s, rig, eye="left").color

    lo, hi = math.log(F_MIN_PX), math.log(F_MAX_PX)
    r_lo = r_hi = None
    x = min(max(math.log(target / _SLOPE), lo), hi)
    best: tuple[float, float, float, SceneSpec, np.ndarray] | None = None  # error, log f, rho
    probes = 0
    while True:
        f = math.exp(x)
        probe_scene = retexture(scene, fx=rig.fx, frequency_px=f)
        image = render_left(probe_scene)
        rho = edge_density(image)
        probes += 1
        err = abs(rho - target)
        if best is None or err < best[0]:
            best = (err, x, rho, probe_scene, np.array(image))  # own copy, kept
        if err <= tol or probes >= _MAX_PROBES:
            break
        if rho < target:
            lo, r_lo = x, rho
        else:
            hi, r_hi = x, rho
        if hi - lo < 1e-3 or (x >= math.log(F_MAX_PX) and rho < target) or (
                x <= math.log(F_MIN_PX) and rho > target):
            break
        width = hi - lo
        if r_lo is not None and r_hi is not None and r_hi > r_lo:
            nxt = lo + (target - r_lo) * width / (r_hi - r_lo)
        else:  # one side known: move by the log ratio (rho ~ f), at most to the middle
            nxt = x + math.log(target / max(rho, 1e-3))
        x = min(max(nxt, lo + 0.1 * width), hi - 0.1 * width)
    err, x, rho, chosen, image = best
    image.setflags(write=False)
    return EdgeSearch(scene=chosen, frequency_px=math.exp(x), edge_density=rho,
                      target=float(target), probes=probes, converged=err <= tol, left=image)
