"""Patch batches for the reference network: one torch ``Dataset`` item per training step.

Item ``k`` of :class:`PatchBatches` is the whole batch of step ``k``, a pure function of
``(seed, k)``: which pairs it cuts its crops from, where, and every positive and negative offset.
So a ``DataLoader`` with any number of worker processes, and a run resumed at step ``k``, see
exactly the batches an uninterrupted run sees.

A batch holds ``crops`` crops, each from another pair. Pairs are balanced: crop ``j`` of the run
(``j = k * crops + b``) comes from pair ``perm_e[j mod N]`` of a fresh permutation ``perm_e`` of
all ``N`` training pairs per epoch ``e = j // N``. A crop is a ``size x size`` block of left
pixels (its left input has the network's halo around it) whose visible pixels (ground truth,
seen in both views; at least :data:`MIN_VISIBLE` of the block, else another place is drawn, up
to 20 times) are the patches; its right input is the strip of the same rows that holds every
patch's positive and negative. For a patch with disparity ``d`` the positive lies at
``x - d + o_pos``, ``o_pos ~ U(-0.5, 0.5)``, the negative at ``x - d + o_neg``,
``|o_neg| ~ U(1.5, 6)`` with a random sign (:mod:`matcher.learned.loss`); patches whose
positive or negative falls outside the right image are dropped.

Workers keep the pairs they have read in a cache of at most ``cache_bytes`` (least recently
used out first), so after the first epoch a batch costs no decoding.
"""

from __future__ import annotations

import math
import pickle
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from matcher.learned.loss import NEGATIVE_OFFSETS, POSITIVE_OFFSET
from stereoforge.errors import StereoforgeError
from synth.jobs.train.sources import TrainPair, TrainSource

__all__ = ["CROP", "CROPS", "MIN_VISIBLE", "Crop", "Failed", "GuardedBatches", "LoaderFailure",
           "PatchBatches"]

#: Side of a crop's block of left pixels.
CROP = 32
#: Crops per batch (each from another pair).
CROPS = 16
#: Smallest share of a crop's pixels that must be patches.
MIN_VISIBLE = 0.3
_STREAM_EPOCH, _STREAM_STEP, _STREAM_VAL = 0, 1, 2


@dataclass(frozen=True, eq=False)
class Crop:
    """One crop of a batch (numpy; the training step turns it into tensors).

    left : (size + 2r, size + 2r) float32; right : (size + 2r, wr + 2r) float32, the strip.
    ys, xs : (N,) int64 patch positions in the block; x_pos, x_neg : (N,) float32 columns of
    their positive and negative in the strip's ``wr`` outputs.
    """

    left: np.ndarray
    right: np.ndarray
    ys: np.ndarray
    xs: np.ndarray
    x_pos: np.ndarray
    x_neg: np.ndarray


class PatchBatches:
    """The batches of a run over ``sources`` (a map-style torch ``Dataset``: ``len`` and
    integer indexing; batch ``k`` is item ``k``).

    Parameters
    ----------
    sources : list of TrainSource
    seed : int
    radius : int
        The network's half patch (its halo).
    split : {"train", "val"}
        ``val`` batches draw from the validation pairs (stream of their own).
    steps : int
        ``len`` of the dataset (a sampler may ask for fewer).
    """

    def __init__(self, sources: list[TrainSource], *, seed: int, radius: int,
                 split: str = "train", steps: int = 10**12, crops: int = CROPS,
                 size: int = CROP, cache_bytes: int = 1 << 30) -> None:
        self.sources, self.seed, self.radius = sources, int(seed), int(radius)
        self.split, self.steps, self.crops, self.size = split, int(steps), int(crops), int(size)
        self.cache_bytes = int(cache_bytes)
        self.pairs = [(s, i) for s in range(len(sources))
                      for i in range(sources[s].n_train if split == "train" else sources[s].n_val)]
        self._cache: OrderedDict = OrderedDict()
        self._cached_bytes = 0

    def __len__(self) -> int:
        return self.steps

    def __getstate__(self) -> dict:  # a worker starts with an empty cache
        state = dict(self.__dict__)
        state["_cache"], state["_cached_bytes"] = OrderedDict(), 0
        return state

    def _pair(self, n: int) -> TrainPair:
        if n in self._cache:
            self._cache.move_to_end(n)
            return self._cache[n]
        s, i = self.pairs[n]
        pair = self.sources[s].load(self.split, i)
        self._cache[n] = pair
        self._cached_bytes += pair.nbytes
        while self._cached_bytes > self.cache_bytes and len(self._cache) > 1:
            _, old = self._cache.popitem(last=False)
            self._cached_bytes -= old.nbytes
        return pair

    def _pair_number(self, j: int) -> int:
        n = len(self.pairs)
        stream = _STREAM_EPOCH if self.split == "train" else _STREAM_VAL
        perm = np.random.default_rng([self.seed, stream, j // n]).permutation(n)
        return int(perm[j % n])

    def __getitem__(self, k: int) -> list[Crop]:
        if not self.pairs:
            raise IndexError(f"no {self.split} pairs")
        stream = _STREAM_STEP if self.split == "train" else _STREAM_VAL
        rng = np.random.default_rng([self.seed, stream, 1 + int(k)])
        out = []
        for b in range(self.crops):
            crop = self._crop(self._pair(self._pair_number(int(k) * self.crops + b)), rng)
            if crop is not None:
                out.append(crop)
        return out

    def _crop(self, pair: TrainPair, rng: np.random.Generator) -> Crop | None:
        r, size = self.radius, self.size
        h, w = pair.left.shape
        if h < size + 2 * r or w < size + 2 * r:
            return None
        for _ in range(20):
            y0 = int(rng.integers(r, h - r - size + 1))
            x0 = int(rng.integers(r, w - r - size + 1))
            vis = pair.visible[y0:y0 + size, x0:x0 + size]
            if vis.mean() >= MIN_VISIBLE:
                break
        else:
            return None
        ys, xs = np.nonzero(vis)
        d = pair.disp[y0:y0 + size, x0:x0 + size][ys, xs].astype(np.float64)
        n = ys.size
        o_pos = rng.uniform(-POSITIVE_OFFSET, POSITIVE_OFFSET, n)
        lo, hi = NEGATIVE_OFFSETS
        o_neg = rng.uniform(lo, hi, n) * np.where(rng.random(n) < 0.5, -1.0, 1.0)
        x_pos = x0 + xs - d + o_pos  # image columns of the right view
        x_neg = x0 + xs - d + o_neg
        inside = (np.minimum(x_pos, x_neg) >= r) & (np.maximum(x_pos, x_neg) <= w - 1 - r)
        if not inside.any():
            return None
        ys, xs, x_pos, x_neg = ys[inside], xs[inside], x_pos[inside], x_neg[inside]
        c0 = int(math.floor(min(x_pos.min(), x_neg.min())))
        c1 = int(math.ceil(max(x_pos.max(), x_neg.max())))
        c1 = max(c1, c0 + 1)  # two columns at least, for the interpolation
        return Crop(
            left=pair.left[y0 - r:y0 + size + r, x0 - r:x0 + size + r],
            right=pair.right[y0 - r:y0 + size + r, c0 - r:c1 + 1 + r],
            ys=ys.astype(np.int64), xs=xs.astype(np.int64),
            x_pos=(x_pos - c0).astype(np.float32), x_neg=(x_neg - c0).astype(np.float32))


class LoaderFailure(StereoforgeError, RuntimeError):
    """The data loader failed in a way that is not a sample's (a worker killed, an exception that
    cannot cross processes)."""


@dataclass(frozen=True)
class Failed:
    """What a ``DataLoader`` worker returns instead of raising. An exception raised in a worker
    is raised again by torch in the trainer with the loader's iterator in its traceback, which
    keeps the workers alive and the interpreter waiting for them at exit: the run never ends."""

    error: BaseException


class GuardedBatches:
    """:class:`PatchBatches` whose failures are returned as :class:`Failed` values, for the
    trainer to raise (a map-style dataset, like the batches it wraps)."""

    def __init__(self, batches: PatchBatches) -> None:
        self.batches = batches

    def __len__(self) -> int:
        return len(self.batches)

    def __getitem__(self, k: int) -> list[Crop] | Failed:
        try:
            return self.batches[k]
        except Exception as exc:  # noqa: BLE001 - travels to the trainer, raised there
            exc.__traceback__, exc.__context__, exc.__cause__ = None, None, None
            try:
                pickle.loads(pickle.dumps(exc))
            except Exception:  # noqa: BLE001 - an exception that does not cross processes
                exc = LoaderFailure(f"step {k}: {type(exc).__name__}: {' '.join(str(exc).split())}")
            return Failed(exc)
