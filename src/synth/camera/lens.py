"""Real cameras of a stereo rig: OpenCV lens distortion, a rectification error, defocus.

A :class:`~synth.camera.rig.StereoRig` describes the *ideal* rectified pair (its ground truth is
``disp0GT.pfm``). :class:`RigErrors` describes how the real cameras that take the images deviate
from it; ``StereoRig(..., errors=RigErrors(...))`` renders images through them and writes the
exact left -> right correspondence as ``flow0.flo`` (see ``docs/formats.md``).

The models (pixel centres at integers, as ``docs/conventions.md``):

* **distortion**, OpenCV's ``(k1, k2, p1, p2, k3)``: a ray ``(x, y, 1)`` of the camera frame
  (undistorted normalised coordinates) is seen at ``u = fx * xd + cx``, ``v = fy * yd + cy`` with
  ``r2 = x^2 + y^2``, ``xd = x (1 + k1 r2 + k2 r2^2 + k3 r2^3) + 2 p1 x y + p2 (r2 + 2 x^2)``,
  ``yd = y (1 + k1 r2 + k2 r2^2 + k3 r2^3) + p1 (r2 + 2 y^2) + 2 p2 x y``;
* **left camera**: at the origin, the world's orientation, intrinsics ``fx, fy, cx, cy`` of the
  rig, distortion ``left``;
* **right camera**: at ``(baseline, 0, 0)``, rotated by ``R = Rz(rz) Ry(ry) Rx(rx)`` (camera ->
  world, degrees about its own centre), focal lengths ``f_scale * (fx, fy)``, principal point
  ``(cx, cy + dy_px)``, distortion ``right``;
* **defocus** (:class:`Defocus`): thin-lens circle of confusion, images only.

The distortion is refused when it folds the image (:func:`stereoforge.validation.check_distortion`)
and rotations beyond :data:`MAX_ROTATION_DEG` are refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
from numba import njit

from stereoforge.errors import ParameterError
from stereoforge.validation import (
    check_distortion,
    check_keys,
    check_real,
    check_rotation_deg,
    check_sequence,
    fail,
)

__all__ = ["Distortion", "Defocus", "RigErrors", "MAX_ROTATION_DEG", "rotation_matrix",
           "distort", "undistort", "pixel_rays", "project"]

#: Largest rotation of the right camera about any axis (degrees): a rectification *error*.
MAX_ROTATION_DEG = 10.0
#: Range of the right camera's focal-length ratio.
F_SCALE_RANGE = (0.8, 1.25)
#: Newton iterations of :func:`undistort` and its convergence test (normalised units).
_NEWTON_ITERS, _NEWTON_TOL = 60, 1e-13


@dataclass(frozen=True)
class Distortion:
    """OpenCV's distortion coefficients ``(k1, k2, p1, p2, k3)`` of one camera (all 0: none)."""

    k1: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0
    k3: float = 0.0

    def __post_init__(self) -> None:
        for name in ("k1", "k2", "p1", "p2", "k3"):
            object.__setattr__(self, name, check_real(getattr(self, name),
                                                      f"Distortion.{name}"))

    @property
    def coeffs(self) -> tuple[float, float, float, float, float]:
        """``(k1, k2, p1, p2, k3)``, OpenCV's order."""
        return (self.k1, self.k2, self.p1, self.p2, self.k3)

    @property
    def is_zero(self) -> bool:
        return not any(self.coeffs)


@dataclass(frozen=True)
class Defocus:
    """Thin-lens defocus of both cameras (applied to the images only).

    A point at depth ``Z`` is imaged as a disc of diameter (circle of confusion, pixels)
    ``c = (f / N) * f / (S - f) * |Z - S| / Z / pitch`` with the focal length ``f = fx * pitch``
    (metres), the focus distance ``S``, the f-number ``N`` and the pixel pitch.

    Parameters
    ----------
    focus_distance : float
        ``S``, metres (in focus: points at that depth).
    f_number : float
        ``N`` (aperture diameter ``f / N``).
    pixel_pitch_um : float
        Sensor pixel pitch, micrometres.
    """

    focus_distance: float
    f_number: float
    pixel_pitch_um: float = 3.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "focus_distance", check_real(
            self.focus_distance, "Defocus.focus_distance", lo=0, lo_open=True,
            fix="pass the in-focus depth in metres"))
        object.__setattr__(self, "f_number", check_real(
            self.f_number, "Defocus.f_number", lo=0.5, hi=64.0, fix="pass an f-number such as 2.8"))
        object.__setattr__(self, "pixel_pitch_um", check_real(
            self.pixel_pitch_um, "Defocus.pixel_pitch_um", lo=0.1, hi=100.0,
            fix="pass the sensor pixel pitch in micrometres (phones ~1, DSLRs ~4-6)"))

    def coc_px(self, depth: np.ndarray, fx: float) -> np.ndarray:
        """Circle-of-confusion diameter (pixels) of each depth (``inf``: a point at infinity).

        Examples
        --------
        >>> Defocus(2.0, 2.0, 5.0).coc_px(np.array([2.0, 1.0]), fx=1000.0).round(3).tolist()
        [0.0, 1.253]
        """
        pitch = self.pixel_pitch_um * 1e-6
        f = fx * pitch
        s = self.focus_distance
        if not s > f:
            raise fail("Defocus.focus_distance", f"more than the focal length {f:.4g} m",
                       f"{s}", fix="focus farther than the lens's focal length")
        z = np.asarray(depth, dtype=np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.where(np.isfinite(z), np.abs(z - s) / z, 1.0)
        return (f / self.f_number) * f / (s - f) * rel / pitch


@dataclass(frozen=True)
class RigErrors:
    """How the real cameras deviate from the ideal rectified rig (defaults: no deviation).

    Parameters
    ----------
    left, right : Distortion
        Lens distortion of each camera.
    rotation_deg : (3,) tuple of float
        ``(rx, ry, rz)``: rotation of the right camera about its own x, y, z axes (degrees,
        applied as ``Rz Ry Rx``, camera -> world); each within ``+-MAX_ROTATION_DEG``.
    dy_px : float
        Vertical offset of the right principal point, pixels (``cy_right = cy + dy_px``).
    f_scale : float
        Right focal lengths over the left's (``fx_right = f_scale * fx``), in [0.8, 1.25].
    defocus : Defocus, optional
        Defocus blur of the images.
    """

    left: Distortion = Distortion()
    right: Distortion = Distortion()
    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    dy_px: float = 0.0
    f_scale: float = 1.0
    defocus: Defocus | None = None

    def __post_init__(self) -> None:
        for name in ("left", "right"):
            if not isinstance(getattr(self, name), Distortion):
                raise fail(f"RigErrors.{name}", "a Distortion", type(getattr(self, name)).__name__)
        rot = check_sequence(self.rotation_deg, "RigErrors.rotation_deg", length=3)
        object.__setattr__(self, "rotation_deg", tuple(
            check_rotation_deg(a, f"RigErrors.rotation_deg[{i}]", limit=MAX_ROTATION_DEG)
            for i, a in enumerate(rot)))
        object.__setattr__(self, "dy_px", check_real(self.dy_px, "RigErrors.dy_px"))
        object.__setattr__(self, "f_scale", check_real(
            self.f_scale, "RigErrors.f_scale", lo=F_SCALE_RANGE[0], hi=F_SCALE_RANGE[1],
            fix="a rectification error is a few per cent: pass a ratio near 1"))
        if self.defocus is not None and not isinstance(self.defocus, Defocus):
            raise fail("RigErrors.defocus", "a Defocus or None", type(self.defocus).__name__)

    @property
    def geometric(self) -> bool:
        """The cameras differ from the ideal rig's (not only defocus)."""
        return not (self.left.is_zero and self.right.is_zero and not any(self.rotation_deg)
                    and self.dy_px == 0.0 and self.f_scale == 1.0)

    def check_image(self, width: int, height: int, fx: float, fy: float, cx: float,
                    cy: float) -> None:
        """Refuse a distortion that folds a ``width`` x ``height`` image of these intrinsics."""
        corners_x = (np.array([-0.5, width - 0.5]) - cx) / fx
        corners_y = (np.array([-0.5, height - 0.5]) - cy) / fy
        r_left = float(np.hypot(np.abs(corners_x).max(), np.abs(corners_y).max()))
        check_distortion(self.left.coeffs, "left distortion", max_radius=r_left)
        s = self.f_scale
        ry = (np.array([-0.5, height - 0.5]) - cy - self.dy_px) / (s * fy)
        r_right = float(np.hypot(np.abs(corners_x / s).max(), np.abs(ry).max()))
        check_distortion(self.right.coeffs, "right distortion", max_radius=r_right)

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"left": list(self.left.coeffs), "right": list(self.right.coeffs),
                               "rotation_deg": list(self.rotation_deg), "dy_px": self.dy_px,
                               "f_scale": self.f_scale}
        if self.defocus is not None:
            out["defocus"] = {"focus_distance": self.defocus.focus_distance,
                              "f_number": self.defocus.f_number,
                              "pixel_pitch_um": self.defocus.pixel_pitch_um}
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RigErrors:
        check_keys(data, "RigErrors.from_dict",
                   ("left", "right", "rotation_deg", "dy_px", "f_scale", "defocus"))
        kw: dict[str, Any] = dict(data)
        for name in ("left", "right"):
            if name in kw:
                kw[name] = Distortion(*check_sequence(kw[name], f"RigErrors.{name}", length=5))
        if kw.get("defocus") is not None:
            kw["defocus"] = Defocus(**kw["defocus"])
        if "rotation_deg" in kw:
            kw["rotation_deg"] = tuple(kw["rotation_deg"])
        return cls(**kw)


# ---------------------------------------------------------------------------- camera maths
def rotation_matrix(rotation_deg: tuple[float, float, float]) -> np.ndarray:
    """``Rz(rz) @ Ry(ry) @ Rx(rx)`` (float64, (3, 3)) of angles in degrees.

    Examples
    --------
    >>> rotation_matrix((0.0, 0.0, 90.0)).round(6).tolist()[0]
    [0.0, -1.0, 0.0]
    """
    rx, ry, rz = (math.radians(a) for a in rotation_deg)
    cx, sx, cy, sy, cz, sz = (math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry),
                              math.cos(rz), math.sin(rz))
    mx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    my = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    mz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return mz @ my @ mx


def distort(x: np.ndarray, y: np.ndarray, coeffs: tuple[float, ...]
            ) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's distortion of undistorted normalised coordinates (float64)."""
    k1, k2, p1, p2, k3 = coeffs
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    return xd, yd


def undistort(xd: np.ndarray, yd: np.ndarray, coeffs: tuple[float, ...]
              ) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`distort` by Newton's method (float64, converged to 1e-13).

    Raises
    ------
    ParameterError
        If it does not converge (a distortion that :func:`check_distortion` would refuse).

    Examples
    --------
    >>> c = (-0.2, 0.05, 0.001, -0.002, 0.0)
    >>> x, y = undistort(*distort(np.array([0.3]), np.array([-0.2]), c), c)
    >>> bool(abs(x[0] - 0.3) < 1e-12 and abs(y[0] + 0.2) < 1e-12)
    True
    """
    xd = np.asarray(xd, dtype=np.float64)
    yd = np.asarray(yd, dtype=np.float64)
    if not any(coeffs):
        return xd.copy(), yd.copy()
    k1, k2, p1, p2, k3 = (float(c) for c in coeffs)
    x, y = xd.copy(), yd.copy()
    flat = (x.reshape(-1), y.reshape(-1), np.ascontiguousarray(xd).reshape(-1),
            np.ascontiguousarray(yd).reshape(-1))
    ex, ey = np.empty(x.size), np.empty(x.size)
    # each Newton step over every point after the test of the largest error over every point:
    # the float64 operations of distort and of the step below, in numpy's order, compiled
    for _ in range(_NEWTON_ITERS):
        if _newton_errors(*flat, k1, k2, p1, p2, k3, ex, ey) < _NEWTON_TOL:
            return x, y
        _newton_step(flat[0], flat[1], ex, ey, k1, k2, p1, p2, k3)
    raise ParameterError(f"distortion {tuple(coeffs)}: undistortion did not converge; use a "
                         "milder distortion")


@njit(cache=True, nogil=True)
def _newton_errors(x, y, xd, yd, k1, k2, p1, p2, k3, ex, ey):  # pragma: no cover - compiled
    """``ex, ey = distort(x, y) - (xd, yd)`` (flat float64 arrays); returns the largest
    ``|ex|, |ey|`` (inf where one is NaN, as numpy's ``max`` would give NaN: no convergence)."""
    worst = 0.0
    for i in range(x.size):
        xi, yi = x[i], y[i]
        r2 = xi * xi + yi * yi
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        e1 = xi * radial + 2.0 * p1 * xi * yi + p2 * (r2 + 2.0 * xi * xi) - xd[i]
        e2 = yi * radial + p1 * (r2 + 2.0 * yi * yi) + 2.0 * p2 * xi * yi - yd[i]
        ex[i], ey[i] = e1, e2
        a1, a2 = abs(e1), abs(e2)
        if not (a1 <= worst):  # larger, or NaN
            worst = a1 if a1 == a1 else np.inf
        if not (a2 <= worst):
            worst = a2 if a2 == a2 else np.inf
    return worst


@njit(cache=True, nogil=True)
def _newton_step(x, y, ex, ey, k1, k2, p1, p2, k3):  # pragma: no cover - compiled
    """One Newton step of :func:`undistort` in place (flat float64 arrays)."""
    for i in range(x.size):
        xi, yi = x[i], y[i]
        r2 = xi * xi + yi * yi
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        dr = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)  # d radial / d r2
        a = radial + 2.0 * xi * xi * dr + 2.0 * p1 * yi + 6.0 * p2 * xi
        b = 2.0 * xi * yi * dr + 2.0 * p1 * xi + 2.0 * p2 * yi
        d = radial + 2.0 * yi * yi * dr + 6.0 * p1 * yi + 2.0 * p2 * xi
        det = a * d - b * b
        x[i] = xi - (d * ex[i] - b * ey[i]) / det
        y[i] = yi - (a * ey[i] - b * ex[i]) / det


def pixel_rays(u: np.ndarray, v: np.ndarray, *, fx: float, fy: float, cx: float, cy: float,
               coeffs: tuple[float, ...]) -> np.ndarray:
    """Camera-frame ray directions ``(x, y, 1)`` (float64, (..., 3)) of distorted pixels."""
    x, y = undistort((np.asarray(u, np.float64) - cx) / fx, (np.asarray(v, np.float64) - cy) / fy,
                     coeffs)
    return np.stack([x, y, np.ones_like(x)], axis=-1)


def project(points_cam: np.ndarray, *, fx: float, fy: float, cx: float, cy: float,
            coeffs: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Distorted pixel coordinates of camera-frame points (..., 3); NaN behind the camera."""
    p = np.asarray(points_cam, dtype=np.float64)
    z = p[..., 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        zz = np.where(z > 0, z, np.nan)
        xd, yd = distort(p[..., 0] / zz, p[..., 1] / zz, coeffs)
    return fx * xd + cx, fy * yd + cy
