"""A figure of the census patterns: the dense spiral bit order and the sparse patterns
(:mod:`matcher.patterns`).

Needs matplotlib, imported inside :func:`draw_patterns` only, so importing this module (or
:mod:`matcher`) does not.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from matcher.patterns import sparse_pattern, spiral_offsets

__all__ = ["draw_patterns"]


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
