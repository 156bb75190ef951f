"""A rectified stereo rig: pinhole intrinsics, baseline, depth <-> disparity.

The conventions are those of ``docs/conventions.md``: pixel centres on integer
coordinates, the world frame is the left camera's frame (x right, y down,
z forward, metres), the right camera sits at ``(baseline, 0, 0)`` and
``d = fx * baseline / Z``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Any, Mapping

import numpy as np

from stereoforge.validation import check_choice, check_int, check_keys, check_real, fail
from synth.camera.lens import RigErrors

__all__ = ["StereoRig"]

_FIELDS = ("width", "height", "fx", "fy", "cx", "cy", "baseline", "near", "far", "errors")


@dataclass(frozen=True)
class StereoRig:
    """Intrinsics and baseline of a rectified stereo pair of identical cameras.

    Parameters
    ----------
    width, height : int
        Image size in pixels (both views).
    fx, fy : float
        Focal lengths in pixels.
    cx, cy : float
        Principal point in pixel coordinates (pixel centres at integers, so the
        centre of a W x H image is ``((W - 1) / 2, (H - 1) / 2)``).
    baseline : float
        Distance between the optical centres in metres; the right camera is at
        ``(baseline, 0, 0)`` in the left camera's frame.
    near, far : float
        Depth range (metres, along the optical axis) the renderer accepts.
    errors : synth.camera.lens.RigErrors, optional
        How the real cameras deviate from this ideal rig (lens distortion, rotation, vertical
        offset, focal ratio, defocus). ``None`` (default): the cameras are this ideal rig. The
        ground truth (disparity, depth, mask) is always that of the ideal rig; with errors the
        images are the real cameras' and :func:`synth.render_pair` adds the exact left -> right
        flow (``docs/formats.md``, *flow0.flo*).

    Examples
    --------
    >>> rig = StereoRig.default(64, 48)
    >>> rig.fx, rig.cx, rig.cy
    (60.0, 31.5, 23.5)
    >>> float(rig.disparity_from_depth(2.0))
    3.0
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    baseline: float
    near: float = 0.1
    far: float = 100.0
    errors: RigErrors | None = None

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            object.__setattr__(self, name, check_int(
                getattr(self, name), f"StereoRig.{name}", lo=0, lo_open=True,
                fix=f"pass the image {name} as a whole number of pixels"))
        for name in ("fx", "fy", "cx", "cy", "baseline", "near", "far"):
            positive = name in ("fx", "fy", "baseline")
            unit = "metres" if name in ("baseline", "near", "far") else "pixels"
            object.__setattr__(self, name, check_real(
                getattr(self, name), f"StereoRig.{name}", lo=0 if positive else None,
                lo_open=True, fix=f"pass a {'positive ' if positive else ''}value in {unit}"))
        if not 0 < self.near < self.far:
            raise fail("StereoRig.near, StereoRig.far", "0 < near < far",
                       f"near={self.near}, far={self.far}",
                       fix="pass a positive near plane closer than the far plane")
        if self.errors is not None:
            if not isinstance(self.errors, RigErrors):
                raise fail("StereoRig.errors", "a synth.camera.RigErrors or None",
                           type(self.errors).__name__)
            self.errors.check_image(self.width, self.height, self.fx, self.fy, self.cx, self.cy)

    @property
    def ideal(self) -> StereoRig:
        """This rig without its camera errors (itself when it has none)."""
        return self if self.errors is None else replace(self, errors=None)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def default(
        cls,
        width: int = 640,
        height: int = 480,
        *,
        fx: float | None = None,
        baseline: float = 0.1,
    ) -> StereoRig:
        """A rig with square pixels and a centred principal point.

        Parameters
        ----------
        width, height : int
            Image size in pixels.
        fx : float, optional
            Focal length in pixels (``fy = fx``); default ``600 * width / 640``
            (a horizontal field of view of about 56 degrees).
        baseline : float
            Baseline in metres.

        Returns
        -------
        StereoRig

        Examples
        --------
        >>> StereoRig.default().K()[0]
        array([600. ,   0. , 319.5])
        """
        f = 600.0 * width / 640.0 if fx is None else fx
        return cls(
            width=width,
            height=height,
            fx=f,
            fy=f,
            cx=(width - 1) / 2.0,
            cy=(height - 1) / 2.0,
            baseline=baseline,
        )

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> StereoRig:
        """Inverse of :meth:`to_dict`; unknown keys raise ``ValueError``.

        Examples
        --------
        >>> rig = StereoRig.default(32, 24)
        >>> StereoRig.from_dict(rig.to_dict()) == rig
        True
        """
        check_keys(data, "StereoRig.from_dict", _FIELDS)
        kw = dict(data)
        if kw.get("errors") is not None:
            kw["errors"] = RigErrors.from_dict(kw["errors"])
        return cls(**kw)

    # ------------------------------------------------------------------ geometry
    def K(self) -> np.ndarray:
        """The (3, 3) float64 intrinsic matrix of either camera.

        Examples
        --------
        >>> StereoRig.default(4, 2, fx=2.0).K()
        array([[2. , 0. , 1.5],
               [0. , 2. , 0.5],
               [0. , 0. , 1. ]])
        """
        return np.array(
            [[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]], dtype=np.float64
        )

    def disparity_from_depth(self, z: np.ndarray | float) -> np.ndarray:
        """Disparity ``fx * baseline / z`` in pixels, computed in float64.

        Parameters
        ----------
        z : array_like of float
            Depth along the optical axis (metres). ``inf`` (no surface) maps to
            ``inf`` (invalid), as do ``0``, negative and NaN depths.

        Returns
        -------
        d : float64 array, same shape as ``z``

        Examples
        --------
        >>> StereoRig.default(64, 48, baseline=0.5).disparity_from_depth([1.0, 30.0, float("inf")])
        array([30.,  1., inf])
        """
        z = np.asarray(z)
        if z.dtype.kind not in "fiub":
            z = z.astype(np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.divide(self.fx * self.baseline, z, out=np.empty(z.shape), dtype=np.float64)
        # invalid z (inf -> d = 0, NaN, <= 0 -> d <= 0 or NaN; z = +0 gives d = +inf already)
        np.copyto(d, np.inf, where=~(d > 0))
        return d

    def depth_from_disparity(self, d: np.ndarray | float) -> np.ndarray:
        """Depth ``fx * baseline / d`` in metres, computed in float64.

        Parameters
        ----------
        d : array_like of float
            Disparity in pixels; ``0``, ``inf``, negative and NaN (no match,
            invalid) all map to ``inf``.

        Returns
        -------
        z : float64 array, same shape as ``d``

        Examples
        --------
        >>> StereoRig.default(64, 48, baseline=0.5).depth_from_disparity([30.0, 0.0, float("inf")])
        array([ 1., inf, inf])
        """
        d = np.asarray(d, dtype=np.float64)
        valid = np.isfinite(d) & (d > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (self.fx * self.baseline) / d
        return np.where(valid, z, np.inf)

    def plane_disparity(self, normal: np.ndarray, c: float, *, eye: str = "left") -> np.ndarray:
        """Exact disparity map of the plane ``normal . X = c`` (world = left camera frame).

        At pixel ``(x, y)`` the ray ``r = K^-1 [x, y, 1]`` of the left camera meets
        the plane at ``1 / Z = (n . r) / c``; the right camera at ``o = (B, 0, 0)``
        at ``1 / Z = (n . r) / (c - n . o)``. Pixels whose ray meets the plane
        behind the camera (or never) get ``inf``.

        Parameters
        ----------
        normal : (3,) array_like of float
            Plane normal (any length).
        c : float
            Plane offset.
        eye : {"left", "right"}

        Returns
        -------
        d : (height, width) float64 array

        Examples
        --------
        >>> rig = StereoRig.default(8, 6)
        >>> float(rig.plane_disparity([0.0, 0.0, -1.0], -2.0, eye="right")[3, 4])
        0.375
        """
        check_choice(eye, "eye", ("left", "right"))
        n = np.asarray(normal, dtype=np.float64)
        if n.shape != (3,) or not np.all(np.isfinite(n)) or not np.any(n):
            raise fail("normal", "a finite non-zero 3-vector", repr(normal))
        offset = float(c) - (n[0] * self.baseline if eye == "right" else 0.0)
        x = (np.arange(self.width, dtype=np.float64) - self.cx) / self.fx
        y = (np.arange(self.height, dtype=np.float64) - self.cy) / self.fy
        if offset == 0.0:  # the plane contains the optical centre: seen edge-on
            return np.full((self.height, self.width), np.inf)
        inv_z = (n[0] * x[None, :] + n[1] * y[:, None] + n[2]) / offset
        return np.where(inv_z > 0, self.fx * self.baseline * inv_z, np.inf)

    def scaled(self, factor: float) -> StereoRig:
        """The same cameras sampled at a different resolution.

        Pixel ``j`` covers ``[j - 0.5, j + 0.5]``, so a point at ``x`` maps to
        ``(x + 0.5) * factor - 0.5``: ``cx' = (cx + 0.5) * factor - 0.5`` and
        ``fx' = fx * factor`` (likewise for y). Disparities scale by ``factor``.

        Parameters
        ----------
        factor : float
            Positive scale; ``width * factor`` and ``height * factor`` must be
            whole numbers.

        Returns
        -------
        StereoRig

        Examples
        --------
        >>> r = StereoRig.default(64, 48).scaled(0.5)
        >>> (r.width, r.height, r.cx, r.cy) == (32, 24, 15.5, 11.5)
        True
        """
        check_real(factor, "factor", lo=0, lo_open=True)
        w, h = self.width * factor, self.height * factor
        if abs(w - round(w)) > 1e-9 or abs(h - round(h)) > 1e-9:
            raise fail("factor", f"a factor that scales {self.width} x {self.height} to whole "
                       "numbers", f"{factor}, a {w} x {h} image",
                       fix="choose a factor that scales width and height to whole numbers")
        return StereoRig(
            width=int(round(w)),
            height=int(round(h)),
            fx=self.fx * factor,
            fy=self.fy * factor,
            cx=(self.cx + 0.5) * factor - 0.5,
            cy=(self.cy + 0.5) * factor - 0.5,
            baseline=self.baseline,
            near=self.near,
            far=self.far,
            errors=None if self.errors is None else replace(
                self.errors, dy_px=self.errors.dy_px * factor),  # coefficients are normalised
        )

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict[str, Any]:
        """Plain ``dict`` of the fields (ints and floats), e.g. for JSON/TOML metadata.

        ``errors`` appears only when the rig has some (a nested dict).

        Examples
        --------
        >>> sorted(StereoRig.default(8, 6).to_dict())
        ['baseline', 'cx', 'cy', 'far', 'fx', 'fy', 'height', 'near', 'width']
        """
        out = asdict(self)
        out.pop("errors")
        if self.errors is not None:
            out["errors"] = self.errors.to_dict()
        return out

    def middlebury_calib(
        self, ndisp: int, vmin: float, vmax: float, doffs: float = 0.0
    ) -> dict[str, Any]:
        """The fields of a Middlebury 2014 ``calib.txt`` for this rig.

        Parameters
        ----------
        ndisp : int
            Conservative bound on the number of disparity levels.
        vmin, vmax : float
            Tight bounds on the valid disparities (pixels).
        doffs : float
            x-difference of the principal points, ``cx1 - cx0`` (Middlebury's
            ``Z = baseline * f / (d + doffs)``). Images rendered by this rig
            share one principal point, so leave it 0 unless you shift them.

        Returns
        -------
        dict
            ``cam0``, ``cam1`` ((3, 3) float64 arrays, written as
            ``"[fx 0 cx; 0 fy cy; 0 0 1]"`` by :func:`matcher.io.format_calib`),
            ``doffs``, ``baseline`` (millimetres), ``width``, ``height``,
            ``ndisp``, ``vmin``, ``vmax``, in that order.

        Examples
        --------
        >>> StereoRig.default(64, 48).middlebury_calib(16, 1.5, 9.0)["cam0"].tolist()
        [[60.0, 0.0, 31.5], [0.0, 60.0, 23.5], [0.0, 0.0, 1.0]]
        """
        check_int(ndisp, "ndisp", lo=0, lo_open=True)
        if not check_real(vmin, "vmin", lo=0) <= check_real(vmax, "vmax", lo=0):
            raise fail("vmin, vmax", "finite 0 <= vmin <= vmax", f"vmin={vmin}, vmax={vmax}",
                       fix="pass the valid disparity range in pixels")
        check_real(doffs, "doffs")

        def cam(cx: float) -> np.ndarray:
            return np.array([[self.fx, 0.0, cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

        return {
            "cam0": cam(self.cx),
            "cam1": cam(self.cx + doffs),
            "doffs": float(doffs),
            "baseline": self.baseline * 1000.0,
            "width": self.width,
            "height": self.height,
            "ndisp": int(ndisp),
            "vmin": float(vmin),
            "vmax": float(vmax),
        }
