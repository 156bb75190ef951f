"""Sparse census transform (SCT) patterns: point-symmetric subsets of the dense spiral.

The seed paper (§3.3, Fig. 6) uses the 16-point, 7 x 7, symmetric pattern of Fife & Archibald
(2013) and "expands" it to windows 3 x 3 ... 21 x 21. The figure is not available to us, so the
pattern is a reconstruction (see ``docs/matcher.md``):

* 7 x 7: the 16 pixels with both ``dy`` and ``dx`` odd, ``{-3, -1, 1, 3}^2`` -- every second
  pixel of every second row around the centre, the classic 16-comparison sparse census;
* extension: the same lattice, ``S(w) = {(dy, dx): dy, dx odd, |dy|, |dx| <= w // 2}``.

Every pattern is point-symmetric (``p in S => -p in S``), a subset of the dense window, listed in
the dense spiral order (:func:`matcher.census.spiral_offsets`), and -- because it is the same
lattice cut by growing squares -- ``S(w)`` is a prefix of ``S(w + 2)``, as the adaptive sparse
method (AWSCT) needs. Rings of even radius hold no lattice point, so a window of side
``4k + 1`` has the same pattern as the one of side ``4k - 1`` (5 x 5 = 3 x 3, 9 x 9 = 7 x 7, ...).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from matcher.census import _check_side, spiral_offsets

__all__ = ["draw_patterns", "sparse_pattern"]


def sparse_pattern(window: int) -> np.ndarray:
    """Offsets of the sparse census pattern of a window, in spiral bit order.

    Parameters
    ----------
    window : int
        Odd window side, ``3 <= window <= 255``.

    Returns
    -------
    (n, 2) int64 array
        ``(dy, dx)`` offsets with ``dy`` and ``dx`` odd; ``n = ((window + 1) // 4 * 2) ** 2``
        (4 for 3 x 3 and 5 x 5, 16 for 7 x 7 and 9 x 9, ..., 100 for 21 x 21).

    References
    ----------
    W. S. Fife and J. K. Archibald, "Improved Census Transforms for Resource-Optimized Stereo
    Vision", IEEE TCSVT 23(1):60-73, 2013. Liaw et al., Sensors 20(9):2537, 2020, Fig. 6.

    Examples
    --------
    >>> sparse_pattern(3).tolist()
    [[-1, 1], [-1, -1], [1, -1], [1, 1]]
    >>> len(sparse_pattern(7))
    16
    """
    dense = spiral_offsets(_check_side(window))
    odd = (dense[:, 0] % 2 == 1) & (dense[:, 1] % 2 == 1)
    return dense[odd]


def _draw_grid(ax, window: int, offsets: np.ndarray, title: str) -> None:
    r = window // 2
    ax.set_xlim(-r - 0.5, r + 0.5)
    ax.set_ylim(r + 0.5, -r - 0.5)  # y down, as on screen
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    for v in np.arange(-r - 0.5, r + 1.0):
        ax.axhline(v, color="0.85", lw=0.4)
        ax.axvline(v, color="0.85", lw=0.4)
    ax.add_patch(_square(0, 0, "black"))
    size = 7 if window <= 9 else (5 if window <= 15 else 3.5)
    for k, (dy, dx) in enumerate(offsets):
        ax.add_patch(_square(dx, dy, "#4c9be8"))
        ax.text(dx, dy, str(k), ha="center", va="center", fontsize=size, color="white")
    ax.set_title(title, fontsize=8)


def _square(x: float, y: float, colour: str):
    from matplotlib.patches import Rectangle

    return Rectangle((x - 0.5, y - 0.5), 1, 1, color=colour)


def draw_patterns(path: str | Path) -> Path:
    """Draw the sparse patterns 3 x 3 ... 21 x 21 and the dense 7 x 7 spiral to a PNG.

    Each cell shows its bit number; the centre is black. Needs matplotlib (imported here only,
    so ``import matcher`` does not need it).

    Parameters
    ----------
    path : str or Path
        Output PNG file (parent folders are created).

    Returns
    -------
    Path
        The written file.

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as d:
    ...     os.path.getsize(draw_patterns(os.path.join(d, "p.png"))) > 0
    True
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(13, 6.2), dpi=110)
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 6)
    _draw_grid(axes[0, 0], 7, spiral_offsets(7), "dense CT 7x7: spiral bit order")
    for ax, w in zip(list(axes.flat)[1:11], range(3, 23, 2), strict=True):
        pat = sparse_pattern(w)
        _draw_grid(ax, w, pat, f"SCT {w}x{w}: {len(pat)} bits")
    axes.flat[-1].axis("off")
    fig.suptitle(
        "Census bit order (ring r starts at (dy,dx)=(0,+r), counter-clockwise on screen) "
        "and the sparse census patterns (odd lattice)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path)
    return path
