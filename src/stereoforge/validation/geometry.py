"""Checks of camera geometry: small rotations and lens distortions that do not fold the image
(:mod:`stereoforge.validation` re-exports them)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stereoforge.validation.checks import check_real, check_sequence, fail, short_repr

__all__ = ["MAX_TANGENTIAL", "check_rotation_deg", "check_distortion"]


def check_rotation_deg(value: Any, name: str, *, limit: float, where: str | None = None) -> float:
    """An angle in degrees within ``[-limit, limit]`` (a small rotation), as ``float``.

    Examples
    --------
    >>> check_rotation_deg(30, "rx", limit=10.0)
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: rx: expected a rotation within +-10.0 degrees, got 30.0; a rectification error is a small rotation: pass degrees, not radians, and at most 10.0
    """
    v = check_real(value, name, where=where)
    if not abs(v) <= limit:
        raise fail(name, f"a rotation within +-{limit} degrees", short_repr(v), where=where,
                   fix=f"a rectification error is a small rotation: pass degrees, not radians, "
                       f"and at most {limit}")
    return v


#: Largest tangential coefficient ``|p1|``, ``|p2|`` of :func:`check_distortion`.
MAX_TANGENTIAL = 0.05


def check_distortion(coeffs: Any, name: str, *, max_radius: float,
                     where: str | None = None) -> tuple[float, ...]:
    """OpenCV ``(k1, k2, p1, p2, k3)`` that map the image one-to-one, as a tuple of floats.

    The radial mapping ``g(r) = r (1 + k1 r^2 + k2 r^4 + k3 r^6)`` (normalised units) must
    increase from the centre up to ``max_radius``, the distorted radius of the image's farthest
    corner: with ``r_f`` the first radius where ``g'(r) = 0``, the bound is ``g(r_f) >
    max_radius``. ``|p1|, |p2| <= 0.05``, and the Jacobian of the whole mapping (tangential terms
    included) must stay positive on the image (checked on a polar grid of 64 x 64 points).

    Examples
    --------
    >>> check_distortion((-0.3, 0.0, 0.0, 0.0, 0.0), "k", max_radius=0.7)
    (-0.3, 0.0, 0.0, 0.0, 0.0)
    >>> check_distortion((-0.6, 0.0, 0.0, 0.0, 0.0), "k", max_radius=0.7)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: k: expected a distortion that does not fold the image: ...
    """
    c = tuple(check_real(v, f"{name}[{i}]", where=where)
              for i, v in enumerate(check_sequence(coeffs, name, length=5, where=where)))
    k1, k2, p1, p2, k3 = c
    r_max = check_real(max_radius, "max_radius", lo=0, lo_open=True)
    for label, p in (("p1", p1), ("p2", p2)):
        if not abs(p) <= MAX_TANGENTIAL:
            raise fail(f"{name} {label}", f"|{label}| <= {MAX_TANGENTIAL}", short_repr(p), where=where,
                       fix="real lenses have tangential coefficients of about 1e-3")
    # first positive root of g'(r) = 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3 (s = r^2)
    roots = np.roots([7.0 * k3, 5.0 * k2, 3.0 * k1, 1.0]) if any((k1, k2, k3)) else []
    real = [float(s.real) for s in np.atleast_1d(roots)
            if abs(s.imag) <= 1e-12 * max(1.0, abs(s)) and s.real > 0]
    coef = f"k1={k1}, k2={k2}, k3={k3}"

    def g(r: float) -> float:
        with np.errstate(over="ignore", invalid="ignore"):
            s = np.float64(r) * r
            return float(r * (1.0 + s * (k1 + s * (k2 + s * k3))))

    r_f = math.sqrt(min(real)) if real else math.inf
    if real and not g(r_f) > r_max:
        raise fail(name, "a distortion that does not fold the image: the radial mapping "
                   "r (1 + k1 r^2 + k2 r^4 + k3 r^6) must increase up to the image corner's "
                   f"distorted radius {r_max:.4g}", f"{coef}, which stops increasing at "
                   f"r = {r_f:.4g} (distorted radius {g(r_f):.4g})", where=where,
                   fix="reduce |k1|, |k2|, |k3| until that radius exceeds the corner's")
    r_hi = min(1.0, r_f)  # the undistorted radius the image reaches (a little beyond)
    while r_hi < r_f and g(r_hi) < 1.05 * r_max:
        r_hi = min(2.0 * r_hi, r_f)
    if p1 or p2:  # the Jacobian of the full mapping on the undistorted image (up to r_hi)
        r, t = np.meshgrid(np.linspace(0.0, r_hi, 64), np.linspace(0.0, 2 * np.pi, 64))
        x, y = r * np.cos(t), r * np.sin(t)
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        radius = r * radial
        dr = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
        a = radial + 2.0 * x * x * dr + 2.0 * p1 * y + 6.0 * p2 * x
        b = 2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y
        d = radial + 2.0 * y * y * dr + 6.0 * p1 * y + 2.0 * p2 * x
        inside = radius <= r_max * 1.05
        if not np.all((a * d - b * b)[inside] > 0):
            raise fail(name, "a distortion that does not fold the image (a positive Jacobian)",
                       f"p1={p1}, p2={p2} with {coef}, which fold it", where=where,
                       fix="reduce |p1|, |p2|")
    return c
