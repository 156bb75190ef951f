"""Pictures of stereo pairs: a fast per-pair preview and the demo contact sheet.

The preview is pure numpy + OpenCV (it is written with every rendered pair, so it must be cheap);
the contact sheet uses matplotlib for its colour bars.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

__all__ = ["colorize_disparity", "disparity_limits", "preview_image", "contact_sheet"]

_INVALID_RGB = (0, 0, 0)


def disparity_limits(disparity: np.ndarray) -> tuple[float, float]:
    """Finite range of a disparity map, ``(0, 1)`` when it has no finite value.

    Parameters
    ----------
    disparity : (H, W) float array
        Disparity, ``inf``/NaN where invalid.

    Returns
    -------
    (vmin, vmax) : tuple of float

    Examples
    --------
    >>> disparity_limits(np.array([[1.0, np.inf], [3.0, 2.0]]))
    (1.0, 3.0)
    """
    finite = disparity[np.isfinite(disparity)]
    if finite.size == 0:
        return 0.0, 1.0
    return float(finite.min()), float(finite.max())


def colorize_disparity(
    disparity: np.ndarray, *, vmin: float | None = None, vmax: float | None = None
) -> np.ndarray:
    """Map disparity to colour (OpenCV's TURBO colormap); invalid pixels are black.

    Parameters
    ----------
    disparity : (H, W) float array
        Disparity in pixels, ``inf``/NaN where invalid.
    vmin, vmax : float, optional
        Colour range; the finite range of ``disparity`` by default.

    Returns
    -------
    (H, W, 3) uint8 array
        RGB image.

    Examples
    --------
    >>> rgb = colorize_disparity(np.array([[0.0, 10.0, np.inf]]))
    >>> rgb.shape, rgb.dtype, rgb[0, 2].tolist()
    ((1, 3, 3), dtype('uint8'), [0, 0, 0])
    """
    disparity = np.asarray(disparity, dtype=np.float64)
    if disparity.ndim != 2:
        raise ValueError(f"disparity must be 2-D (H, W), got shape {disparity.shape}")
    lo, hi = disparity_limits(disparity)
    lo = lo if vmin is None else float(vmin)
    hi = hi if vmax is None else float(vmax)
    span = hi - lo if hi > lo else 1.0
    valid = np.isfinite(disparity)
    scaled = np.zeros(disparity.shape, dtype=np.uint8)
    scaled[valid] = np.clip((disparity[valid] - lo) / span * 255.0 + 0.5, 0, 255).astype(np.uint8)
    rgb = cv2.applyColorMap(scaled, cv2.COLORMAP_TURBO)[..., ::-1].copy()
    rgb[~valid] = _INVALID_RGB
    return rgb


def _mask_rgb(mask: np.ndarray) -> np.ndarray:
    return np.repeat(np.asarray(mask, dtype=np.uint8)[..., None], 3, axis=2)


def preview_image(
    left: np.ndarray, right: np.ndarray, disparity: np.ndarray, mask: np.ndarray
) -> np.ndarray:
    """One row: left, right, colour-mapped left disparity and occlusion mask, side by side.

    Parameters
    ----------
    left, right : (H, W, 3) uint8 array
    disparity : (H, W) float array
    mask : (H, W) uint8 array
        255 visible in both views, 128 occluded, 0 no ground truth.

    Returns
    -------
    (H, 4 W + 6, 3) uint8 array

    Examples
    --------
    >>> img = np.zeros((4, 5, 3), np.uint8)
    >>> preview_image(img, img, np.ones((4, 5)), np.zeros((4, 5), np.uint8)).shape
    (4, 26, 3)
    """
    gap = np.full((left.shape[0], 2, 3), 255, dtype=np.uint8)
    parts = [left, gap, right, gap, colorize_disparity(disparity), gap, _mask_rgb(mask)]
    return np.concatenate(parts, axis=1)


def contact_sheet(rows: Sequence[tuple[str, object]], path: str | Path, *, dpi: int = 100) -> Path:
    """Draw a contact sheet: one row per scene with left, right, disparity (+ colour bar), mask.

    Parameters
    ----------
    rows : sequence of (name, pair)
        ``pair`` has ``left``, ``right``, ``disp_left`` and ``mask_left`` attributes
        (a :class:`synth.pair.StereoPair`).
    path : str or Path
        PNG to write (atomically: temporary name, then rename).
    dpi : int

    Returns
    -------
    Path
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    n = len(rows)
    if n == 0:
        raise ValueError("contact_sheet needs at least one row")
    h, w = rows[0][1].left.shape[:2]
    aspect = h / w
    fig, axes = plt.subplots(n, 4, figsize=(4 * 3.2, n * 3.2 * aspect + 0.6), squeeze=False)
    titles = ["left", "right", "left disparity (px)", "occlusion mask"]
    for r, (name, pair) in enumerate(rows):
        lo, hi = disparity_limits(pair.disp_left)
        disp = np.where(np.isfinite(pair.disp_left), pair.disp_left, np.nan)
        cmap = plt.get_cmap("turbo").copy()
        cmap.set_bad("black")
        panels = [
            dict(X=pair.left),
            dict(X=pair.right),
            dict(X=disp, cmap=cmap, vmin=lo, vmax=hi),
            dict(X=pair.mask_left, cmap="gray", vmin=0, vmax=255),
        ]
        for c, kw in enumerate(panels):
            ax = axes[r, c]
            im = ax.imshow(interpolation="nearest", **kw)
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(titles[c], fontsize=9)
            if c == 0:
                ax.set_ylabel(name, fontsize=9)
            if c == 2:
                fig.colorbar(im, ax=ax, fraction=0.046, pad=0.02).ax.tick_params(labelsize=7)
    fig.text(0.5, 0.005, "mask: white = visible in both, grey = occluded, black = no ground truth",
             ha="center", fontsize=8)
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    from matcher.io import save_figure_atomic

    try:
        return save_figure_atomic(fig, path, dpi=dpi)
    finally:
        plt.close(fig)
