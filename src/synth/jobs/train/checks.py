"""What ``stereoforge train`` checks: every option before any work, the crop against the smallest
image once the data is open, memory that cannot be had, and a run that learned nothing.

Each check raises one :class:`~stereoforge.errors.StereoforgeError` whose message names the option
and the fix: :class:`~stereoforge.errors.ParameterError` for bad input (exit 2 on the command
line), :class:`TrainOutOfMemory` for memory the machine does not have (exit 1).
"""

from __future__ import annotations

import re
import time
from typing import Any

from matcher.learned.device import check_device
from stereoforge.errors import ParameterError, StereoforgeError
from stereoforge.validation import check_int, check_real
from synth.jobs.train.patches import MIN_VISIBLE
from synth.jobs.train.sources import TrainSource

__all__ = ["MAX_CROP", "MAX_CROPS", "MAX_MINUTES", "MAX_STEPS", "TrainOutOfMemory",
           "check_learned", "check_options", "check_sizes", "out_of_memory"]

#: Upper bounds of the budget and of a batch: a typo (``--minutes 1e9``, ``--crops 100000``) is
#: refused before any work, not met as an overflow or an allocation later.
MAX_MINUTES = 366 * 24 * 60.0
MAX_STEPS = 10**9
MAX_CROPS = 4096
MAX_CROP = 4096


class TrainOutOfMemory(StereoforgeError, RuntimeError):
    """torch or numpy could not allocate what the run needs (an environment error)."""


def check_options(cfg: Any, *, device: str, workers: int, threads: int | None,
                  checkpoint_minutes: float, row_steps: int) -> str:
    """Check every option of a run (``cfg`` a :class:`~synth.jobs.train.TrainConfig`) before any
    work; the device name (:func:`check_device`)."""
    if (cfg.minutes is None) == (cfg.steps is None):
        raise ParameterError("train: give exactly one budget, --minutes M or --steps N")
    if cfg.minutes is not None:
        check_real(cfg.minutes, "--minutes", lo=0, lo_open=True, hi=MAX_MINUTES)
    if cfg.steps is not None:
        check_int(cfg.steps, "--steps", lo=1, hi=MAX_STEPS)
    if not str(cfg.out).endswith(".pt"):
        raise ParameterError(f"--out: expected a .pt model file, got {cfg.out!r}")
    check_int(cfg.seed, "--seed", lo=0, hi=2**63 - 1)
    cfg.architecture()  # the network's name and options, within its limits
    check_int(cfg.crops, "--crops", lo=1, hi=MAX_CROPS)
    check_int(cfg.crop, "--crop", lo=4, hi=MAX_CROP)
    check_real(cfg.lr, "lr", lo=0, lo_open=True)
    check_real(cfg.val_fraction, "val_fraction", lo=0, hi=1, hi_open=True)
    check_int(workers, "--workers", lo=0, hi=256)
    if threads is not None:
        check_int(threads, "--threads", lo=1, hi=4096)
    check_real(checkpoint_minutes, "--checkpoint-minutes", lo=0)
    check_int(row_steps, "row_steps", lo=1)
    return check_device(device, "--device")


def check_sizes(cfg: Any, sources: list[TrainSource]) -> None:
    """Refuse a crop that, with the network's halo, does not fit the smallest image of a source
    (it would train on nothing, or skip that source's small images without a word)."""
    arch = cfg.architecture()
    halo = arch.halo
    need = cfg.crop + 2 * halo
    for s in sources:
        if s.smallest is None or min(s.smallest) >= need:
            continue
        h, w = s.smallest
        fits = min(h, w) - 2 * halo
        fix = (f"use --crop {fits} or less" if fits >= 4 else
               f"use a network with a smaller halo (this one sees {arch.patch}x{arch.patch} "
               "patches: fewer --layers)")
        raise ParameterError(f"--crop {cfg.crop} with the {arch.NAME} network of "
                             f"{arch.describe()} needs images of at least {need}x{need} pixels "
                             f"(the crop and the network's halo of {halo}); the smallest of "
                             f"{s.spec} is {h}x{w}: {fix}")


def check_learned(cfg: Any, *, steps: int, patches: int, start_clock: float) -> None:
    """Refuse to write a model that learned nothing: no step, or no patch in any crop."""
    if steps == 0:
        spent = time.monotonic() - start_clock
        raise ParameterError(f"--minutes {cfg.minutes:g}: the budget ran out before the first "
                             f"step ({spent:.1f} s went to opening the data and starting the "
                             "workers); no model written: give a larger --minutes (or --steps)")
    if patches == 0:
        raise ParameterError(f"train: {steps} steps found no patch to learn from (no "
                             f"{cfg.crop}x{cfg.crop} crop had {MIN_VISIBLE:.0%} of its pixels "
                             "with ground truth, seen in both views, and their matches inside "
                             "the right view); no model written: use a smaller --crop or data "
                             "with more ground truth")


def _amount(text: str) -> str:
    found = re.search(r"allocate (?:memory: you tried to allocate )?"
                      r"([0-9.]+ ?[KMGT]?i?B\b|[0-9]+ bytes)", text)
    if found is None:
        return "the memory it needed"
    amount = found.group(1)
    if amount.endswith(" bytes"):
        amount = f"{int(amount.split()[0]) / 2**30:.1f} GiB"
    return amount


def out_of_memory(exc: BaseException, cfg: Any, device: str) -> TrainOutOfMemory | None:
    """The error to raise for ``exc`` if it is an allocation failure (torch's CPU allocator, CUDA
    out of memory, numpy's ``MemoryError``): how much could not be had and for what."""
    text = " ".join(str(exc).split())
    if not (isinstance(exc, MemoryError) or "out of memory" in text.lower()
            or "can't allocate memory" in text):
        return None
    arch = cfg.architecture()
    return TrainOutOfMemory(
        f"out of memory: could not allocate {_amount(text)} for the {arch.NAME} network of "
        f"{arch.describe()} on a batch of {cfg.crops} crops of {cfg.crop}x{cfg.crop} pixels "
        f"(device {device}); use a smaller network (--arch-option) or fewer --crops, a smaller "
        "--crop, or a machine with more memory")
