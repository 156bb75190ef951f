"""How a golden render is compared: the tolerances of :mod:`synth.jobs.golden`'s render check.

A fresh render of a golden scene passes when it is within :data:`TOLERANCES` of the stored pair
(the rules are in :mod:`synth.jobs.golden`'s docstring); :func:`compare_render` measures it and
names every file that fails. :func:`records_differ` lists the differences of two JSON records
(stored metrics against fresh ones), key path by key path.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["TOLERANCES", "RenderDiff", "boundary_pixels", "compare_render", "disparity_stats",
           "image_stats", "records_differ"]

#: Render-check tolerances (see the module docstring).
TOLERANCES: dict[str, float] = {
    "disparity_abs_px": 1e-3,
    "boundary_px": 1,
    "boundary_fraction": 0.005,
    "image_mean_abs": 1.0,
    "image_p99_abs": 10.0,
}

@dataclass(frozen=True)
class RenderDiff:
    """Fresh render against the stored pair of one golden scene.

    Attributes
    ----------
    scene : str
    image_mean_abs, image_p99_abs, image_max_abs : float
        Largest over ``im0``/``im1`` of the mean, 99th percentile and maximum ``|ΔI|``.
    disparity_max_abs : float
        Largest ``|Δd|`` (px) over ``disp0``/``disp1`` where both are finite, off boundaries.
    boundary_pixels : int
        Pixels (largest over the maps) that differ beyond tolerance within 1 px of a boundary.
    mask_changed : int
        Pixels whose occlusion-mask code changed.
    """

    scene: str
    image_mean_abs: float
    image_p99_abs: float
    image_max_abs: float
    disparity_max_abs: float
    boundary_pixels: int
    mask_changed: int


def boundary_pixels(mask: np.ndarray, disp: np.ndarray, radius: int) -> np.ndarray:
    """Pixels within ``radius`` px (Chebyshev) of a mask-code change or a > 1 px disparity jump."""
    edge = np.zeros(mask.shape, bool)
    d = np.where(np.isfinite(disp), disp, -1e6).astype(np.float64)
    for a, b in ((np.s_[:, 1:], np.s_[:, :-1]), (np.s_[1:, :], np.s_[:-1, :])):
        jump = (mask[a] != mask[b]) | (np.abs(d[a] - d[b]) > 1.0)
        edge[a] |= jump
        edge[b] |= jump
    out = edge.copy()
    pad = np.pad(edge, radius)
    h, w = edge.shape
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            out |= pad[radius + dy:radius + dy + h, radius + dx:radius + dx + w]
    return out


def image_stats(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float]:
    diff = np.abs(a.astype(np.int16) - b.astype(np.int16)).astype(np.float64)
    return float(diff.mean()), float(np.percentile(diff, 99)), float(diff.max())


def disparity_stats(new: np.ndarray, old: np.ndarray) -> tuple[float, int, int]:
    """(max |Δd| where both finite, pixels beyond tolerance, finite-pattern changes)."""
    both = np.isfinite(new) & np.isfinite(old)
    diff = np.abs(new[both].astype(np.float64) - old[both])
    bad = int((diff > TOLERANCES["disparity_abs_px"]).sum())
    return (float(diff.max()) if diff.size else 0.0), bad, int(
        (np.isfinite(new) != np.isfinite(old)).sum())


def compare_render(name: str, fresh: Any, stored: Any, failures: list[str]) -> RenderDiff:
    radius = int(TOLERANCES["boundary_px"])
    budget = TOLERANCES["boundary_fraction"] * stored.disp_left.size
    stats = [image_stats(fresh.left, stored.left), image_stats(fresh.right, stored.right)]
    for fname, (mean, p99, _) in zip(("im0.png", "im1.png"), stats):
        if mean > TOLERANCES["image_mean_abs"] or p99 > TOLERANCES["image_p99_abs"]:
            failures.append(f"{name}/{fname}: fresh render differs: mean |dI| = {mean:.3f} "
                            f"(<= {TOLERANCES['image_mean_abs']}), p99 = {p99:.1f} "
                            f"(<= {TOLERANCES['image_p99_abs']})")
    near = boundary_pixels(stored.mask_left, stored.disp_left, radius)
    max_abs, worst_boundary = 0.0, 0
    for fname, new, old in (("disp0.pfm", fresh.disp_left, stored.disp_left),
                            ("disp1.pfm", fresh.disp_right, stored.disp_right)):
        both = np.isfinite(new) & np.isfinite(old)
        bad = np.zeros(new.shape, bool)
        bad[both] = np.abs(new[both].astype(np.float64) - old[both]) > TOLERANCES[
            "disparity_abs_px"]
        bad |= np.isfinite(new) != np.isfinite(old)
        # disp1 is the right view's map: its boundaries come from itself
        region = near if fname == "disp0.pfm" else boundary_pixels(
            np.isfinite(old).astype(np.uint8), old, radius)
        off = bad & ~region
        if both.any():
            max_abs = max(max_abs, float(np.abs(new[both & ~region].astype(np.float64)
                                                - old[both & ~region]).max(initial=0.0)))
        worst_boundary = max(worst_boundary, int((bad & region).sum()))
        if off.any() or (bad & region).sum() > budget:
            failures.append(f"{name}/{fname}: fresh ground truth differs beyond "
                            f"{TOLERANCES['disparity_abs_px']} px at {int(off.sum())} pixels off "
                            f"boundaries and {int((bad & region).sum())} near them "
                            f"(<= {budget:.0f})")
    changed = fresh.mask_left != stored.mask_left
    worst_boundary = max(worst_boundary, int((changed & near).sum()))
    if (changed & ~near).any() or (changed & near).sum() > budget:
        failures.append(f"{name}/mask0nocc.png: fresh mask differs at {int((changed & ~near).sum())}"
                        f" pixels off boundaries and {int((changed & near).sum())} near them "
                        f"(<= {budget:.0f})")
    return RenderDiff(name, max(s[0] for s in stats), max(s[1] for s in stats),
                      max(s[2] for s in stats), max_abs, worst_boundary, int(changed.sum()))


def records_differ(new: Any, old: Any, path: str = "") -> list[str]:
    if isinstance(new, dict) and isinstance(old, dict):
        out = []
        for k in sorted(set(new) | set(old)):
            if k not in old or k not in new:
                out.append(f"{path}{k}: {'missing' if k not in new else 'new'}")
            else:
                out += records_differ(new[k], old[k], f"{path}{k}.")
        return out
    if new != old or type(new) is not type(old):
        return [f"{path.rstrip('.')}: stored {old!r}, now {new!r}"]
    return []
