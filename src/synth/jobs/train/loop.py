"""``stereoforge train``: the reference network on stereoforge datasets and real scenes.

:func:`train` runs the loop: a torch ``DataLoader`` with worker processes over
:class:`synth.jobs.train.patches.PatchBatches` (built on :class:`synth.StereoDataset` and the
readers of :mod:`matcher.io`), Adam on the hinge loss of :mod:`matcher.learned.loss`, and

- a budget of ``steps`` or of ``minutes`` of wall time counted from the start of the job (data
  loading included);
- the validation loss every :data:`ROW_STEPS` steps on fixed validation batches, and one CSV row
  per range of steps beside the model (``MODEL.csv``: train and validation loss, patches/s);
- a checkpoint (``MODEL.pt.ckpt``, atomic) every ``checkpoint_minutes``, on Ctrl-C or SIGTERM
  (after the step in progress) and at the end. ``resume=True`` continues from it: on the CPU the
  batches of step ``k`` depend only on ``(seed, k)`` and deterministic algorithms are on, so a
  run resumed after a kill ends with the weights an uninterrupted one ends with (``steps``
  budget; a ``minutes`` budget stops where the clock says);
- at the end, the box aggregation the model uses by default chosen on the validation pairs
  (smallest bad-3 among :data:`AGGREGATES`), then the model file, atomically.

Every option is checked before any work (ranges, the device, the architecture's one limit of
:meth:`matcher.learned.registry.Arch.from_options`, the crop and the network's halo against the
smallest image). A failure in a ``DataLoader`` worker (a corrupt sample) comes back to this
process as a value and ends the run with one error naming the sample and its file; the workers
stop, and the last checkpoint stays as it was. Memory that cannot be had ends it with
:class:`TrainOutOfMemory` (how much, and for what). A run that learned nothing (no step, or no
patch in any crop) writes no model.
"""

from __future__ import annotations

import csv
import io
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from matcher.io import atomic_write_bytes
from matcher.io.atomic import claim_output
from matcher.learned import model_bytes, resolve_device
from matcher.learned.model import LearnedModel
from stereoforge.errors import DatasetError
from synth.jobs.train.aggregate import AGGREGATES, SELECT_PAIRS, aggregate_bad3, choose_aggregate
from synth.jobs.train.checkpoint import State, load_checkpoint, save_checkpoint
from synth.jobs.train.checks import (TrainOutOfMemory, check_learned, check_options, check_sizes,
                                     out_of_memory)
from synth.jobs.train.config import TrainConfig, TrainInterrupted, TrainResult
from synth.jobs.train.patches import CROPS, Failed, GuardedBatches, LoaderFailure, PatchBatches
from synth.jobs.train.sources import TrainSource, open_sources
from synth.jobs.train.steps import batch_loss, one_pass_loss, val_loss

__all__ = ["AGGREGATES", "CSV_COLUMNS", "GPU_CROPS", "ROW_STEPS", "TrainConfig",
           "TrainInterrupted", "TrainOutOfMemory", "TrainResult", "aggregate_bad3",
           "default_crops", "train"]

#: Steps per CSV row (and per validation loss).
ROW_STEPS = 100
#: Validation batches the validation loss averages over.
VAL_BATCHES = 8
#: Crops per step by default on a GPU (the CPU's default is :data:`CROPS`): a step of 16 crops
#: is bound by per-step overheads there, not by the GPU.
GPU_CROPS = 256
CSV_COLUMNS = ("step_from", "step_to", "seconds", "train_loss", "val_loss", "patches",
               "patches_per_s", "lr")


def _identity_collate(batch):
    return batch


def _worker_init(_worker_id: int) -> None:
    # Ctrl-C and SIGTERM are the main process's to handle: it stops after the step in
    # progress, writes the checkpoint and shuts the workers down
    from synth.dataset.engine.tasks import die_with_parent

    die_with_parent()  # a killed trainer leaves no worker behind
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def default_crops(device: str) -> int:
    """Crops per step by default: :data:`CROPS` on the CPU, :data:`GPU_CROPS` on a GPU."""
    return CROPS if resolve_device(device).type == "cpu" else GPU_CROPS


def _loader(batches: PatchBatches, start: int, stop: int, workers: int):
    from torch.utils.data import DataLoader

    kwargs = {}
    if workers > 0:
        # spawned, not forked: a fork of this process (torch's and OpenCV's thread pools
        # running) can deadlock in the child, as cv2.setNumThreads did in a forked worker
        kwargs = {"num_workers": workers, "worker_init_fn": _worker_init, "prefetch_factor": 4,
                  "multiprocessing_context": "spawn", "persistent_workers": False}
    return DataLoader(GuardedBatches(batches), batch_size=None, sampler=range(start, stop),
                      collate_fn=_identity_collate, **kwargs)


def _paths(out: str) -> tuple[Path, Path, Path]:
    model = Path(out)
    return model, model.with_suffix(".csv"), Path(f"{model}.ckpt")


def _csv_bytes(rows: list[dict]) -> bytes:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=CSV_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue().encode()


def train(cfg: TrainConfig, *, device: str = "auto", resume: bool = False,
          overwrite: bool = False, workers: int = 2, threads: int | None = None,
          checkpoint_minutes: float = 2.0, log: Callable[[str], None] | None = None,
          show_progress: bool = True, row_steps: int = ROW_STEPS,
          one_pass: bool | None = None) -> TrainResult:
    """Train the reference network (see the module docstring).

    Parameters
    ----------
    cfg : TrainConfig
    device : {"auto", "cpu", "cuda[:N]"}
    resume : bool
        Continue from ``MODEL.pt.ckpt``.
    overwrite : bool
        Start afresh over an existing model or checkpoint.
    workers : int
        ``DataLoader`` worker processes (0: load in this process).
    threads : int, optional
        torch's threads for the network (default: torch's own choice).
    checkpoint_minutes : float
        Wall time between checkpoints.
    row_steps : int
        Steps per CSV row and validation loss (:data:`ROW_STEPS`).
    one_pass : bool, optional
        A step's crops through the network in one pass and their patches sampled on the device
        (:func:`_one_pass_loss`); default: on a GPU. The CPU's default, crop by crop, keeps its
        results (and ``resume``'s equality) as they were.

    Raises
    ------
    TrainInterrupted
        After Ctrl-C / SIGTERM, once the checkpoint is written.
    """
    start_clock = time.monotonic()
    say = log or (lambda _m: None)
    device = check_options(cfg, device=device, workers=workers, threads=threads,
                           checkpoint_minutes=checkpoint_minutes, row_steps=row_steps)
    model_path, csv_path, ckpt_path = _paths(cfg.out)
    for parent in (model_path.parent, *model_path.parent.parents):
        if parent.exists() and not parent.is_dir():  # --out under a file
            raise DatasetError(f"--out {cfg.out}: {parent} is a file, not a folder; choose "
                               "another --out")
    if not model_path.parent.is_dir():
        raise FileNotFoundError(f"--out: the folder {model_path.parent} does not exist; create it")
    for p in (model_path, csv_path, ckpt_path):
        if p.exists() and not p.is_file():  # a folder (or a pipe) of the output's name
            raise DatasetError(f"--out {cfg.out}: {p} is not a regular file (a folder?); "
                               "remove it or choose another --out")
    if not resume and not overwrite:
        for p in (ckpt_path, model_path):
            if p.exists():
                hint = "add --resume to continue it" if p == ckpt_path else "choose another --out"
                raise DatasetError(f"{p} exists; {hint}, or --overwrite to start afresh")
    with claim_output(model_path, (model_path, csv_path, ckpt_path), say):
        failure = None
        try:
            return _train_claimed(cfg, start_clock, say, device=device, resume=resume,
                                  workers=workers, threads=threads,
                                  checkpoint_minutes=checkpoint_minutes,
                                  show_progress=show_progress, row_steps=row_steps,
                                  one_pass=one_pass)
        except (MemoryError, RuntimeError) as exc:
            failure = out_of_memory(exc, cfg, device)
            if failure is None:
                raise
        raise failure


@dataclass
class _Run:
    """One run's parts, as its phases hand them on."""

    cfg: TrainConfig
    start_clock: float
    say: Callable[[str], None]
    dev: torch.device
    one_pass: bool
    step_loss: Callable
    sources: list[TrainSource]
    net: torch.nn.Module
    opt: torch.optim.Optimizer
    state: State
    batches: PatchBatches
    val_batches: list
    workers: int
    paths: tuple[Path, Path, Path]

    @property
    def n_val(self) -> int:
        return sum(s.n_val for s in self.sources)


def _train_claimed(cfg: TrainConfig, start_clock: float, say: Callable[[str], None], *,
                   device: str, resume: bool, workers: int, threads: int | None,
                   checkpoint_minutes: float, show_progress: bool, row_steps: int,
                   one_pass: bool | None) -> TrainResult:
    """:func:`train` once this process holds the output's lock: prepare, step, finish."""
    run = _prepare(cfg, start_clock, say, device=device, resume=resume, workers=workers,
                   threads=threads, one_pass=one_pass)
    _steps(run, checkpoint_minutes=checkpoint_minutes, show_progress=show_progress,
           row_steps=row_steps)
    return _finish(run, row_steps=row_steps)


def _prepare(cfg: TrainConfig, start_clock: float, say: Callable[[str], None], *, device: str,
             resume: bool, workers: int, threads: int | None, one_pass: bool | None) -> _Run:
    """The data, checked against the network's halo, the network and its optimiser (from the
    checkpoint with ``resume``), the batches and the fixed validation batches."""
    paths = _paths(cfg.out)
    model_path, _, ckpt_path = paths
    dev = resolve_device(device)
    one_pass = dev.type != "cpu" if one_pass is None else bool(one_pass)
    sources = open_sources(cfg.sources, val_fraction=cfg.val_fraction)
    for note in (n for s in sources for n in s.notes):
        say(note)
    check_sizes(cfg, sources)
    blob = load_checkpoint(ckpt_path, cfg, sources) if resume else None
    if blob is not None and blob.get("finished") and model_path.is_file():
        raise DatasetError(f"--resume: {model_path} is finished ({blob['state']['step']} steps); "
                           "train a new model with another --out")
    if threads is not None:
        torch.set_num_threads(int(threads))
    if dev.type == "cpu" and not torch.are_deterministic_algorithms_enabled():
        # its first call imports torch._inductor, which crashes a process where Mesa's llvmpipe
        # is loaded (it renders): such a process calls it itself before its first render
        torch.use_deterministic_algorithms(True)
    torch.manual_seed(cfg.seed)
    arch = cfg.architecture()
    net = arch.network().to(dev)
    opt = torch.optim.Adam(net.parameters(), lr=cfg.lr)
    state = State()
    if blob is not None:
        net.load_state_dict(blob["net"])
        opt.load_state_dict(blob["opt"])
        state = State(**blob["state"])
        say(f"resuming {ckpt_path} at step {state.step} ({state.seconds:.0f} s trained)")
    n_train = sum(s.n_train for s in sources)
    n_val = sum(s.n_val for s in sources)
    say(f"training on {n_train} pairs ({', '.join(s.name for s in sources)}), validating on "
        f"{n_val}; {arch.NAME} network of {arch.describe()}, {cfg.crops} crops of "
        f"{cfg.crop}x{cfg.crop} per step{' in one pass' if one_pass else ''}, device {dev}")
    batches = PatchBatches(sources, seed=cfg.seed, radius=arch.halo, crops=cfg.crops,
                           size=cfg.crop)
    val = PatchBatches(sources, seed=cfg.seed, radius=arch.halo, split="val",
                       crops=cfg.crops, size=cfg.crop)
    t_val = time.monotonic()
    val_batches = [val[i] for i in range(VAL_BATCHES)] if val.pairs else []
    say(f"{len(val_batches)} validation batches cut in {time.monotonic() - t_val:.1f} s")
    return _Run(cfg, start_clock, say, dev, one_pass, one_pass_loss if one_pass else batch_loss,
                sources, net, opt, state, batches, val_batches, workers, paths)


def _row(run: _Run, lr: float, row_steps: int) -> dict:
    """The CSV row of the steps since the last one (the validation loss now), and a new row
    begun."""
    state = run.state
    v = val_loss(run.net, run.val_batches, run.dev, run.step_loss)
    row = {"step_from": state.step - (state.step - 1) % row_steps,
           "step_to": state.step, "seconds": round(state.seconds, 2),
           "train_loss": round(state.row_loss / max(state.row_count, 1), 6),
           "val_loss": "" if v is None else round(v, 6), "patches": state.patches,
           "patches_per_s": round(state.row_patches / max(state.row_seconds, 1e-9), 1),
           "lr": lr}
    state.rows.append(row)
    state.row_loss, state.row_count, state.row_patches, state.row_seconds = 0.0, 0, 0, 0.0
    return row


def _next_batch(loader: Any, step: int) -> tuple[Any, BaseException | None]:
    """The loader's next batch, or what to raise: its own failure (a worker killed, ...) as
    one error, or a sample's. Returned, not raised, so that the caller raises it where the
    loader is let go: a traceback holding this frame would keep the loader (and its worker
    processes) alive."""
    try:
        batch = next(loader)
    except Exception as exc:  # noqa: BLE001 - the loader's own (a worker killed, ...)
        return None, LoaderFailure(f"the data loader failed at step {step}: "
                                   f"{' '.join(str(exc).split())[:300]}")
    if isinstance(batch, Failed):
        return None, batch.error
    return batch, None


def _steps(run: _Run, *, checkpoint_minutes: float, show_progress: bool, row_steps: int) -> None:
    """Step until the budget is spent or a signal comes (then the checkpoint is written and
    :class:`TrainInterrupted` raised): a CSV row every ``row_steps``, a checkpoint every
    ``checkpoint_minutes``."""
    cfg, state, net, opt = run.cfg, run.state, run.net, run.opt
    _, csv_path, ckpt_path = run.paths
    total = cfg.steps if cfg.steps is not None else 10**12
    budget = None if cfg.minutes is None else 60.0 * cfg.minutes
    stop = {"signal": None}
    handlers = {}

    def on_signal(signum, _frame):
        stop["signal"] = signal.Signals(signum).name

    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            handlers[sig] = signal.signal(sig, on_signal)
    bar = None
    loader = iter(())
    try:
        from synth._util.progress import progress

        bar = progress(total=cfg.steps if cfg.steps is not None else int(budget), initial=0,
                       desc="train", unit="step" if cfg.steps is not None else "s",
                       enabled=show_progress)
        last_ckpt = time.monotonic()
        run_start, run_seconds0 = time.monotonic(), state.seconds
        loader = (iter(_loader(run.batches, state.step, total, run.workers))
                  if state.step < total else iter(()))
        while state.step < total:
            elapsed = run_seconds0 + (time.monotonic() - run_start)
            if budget is not None and (time.monotonic() - run.start_clock) + run_seconds0 >= budget:
                break
            if stop["signal"]:
                break
            progress_share = (state.step / total) if cfg.steps is not None else elapsed / budget
            lr = cfg.lr * (0.1 if progress_share >= 0.8 else 1.0)
            for group in opt.param_groups:
                group["lr"] = lr
            t0 = time.monotonic()
            batch, failure = _next_batch(loader, state.step)
            if failure is not None:  # raised here, outside any handler: no traceback keeps
                raise failure        # the loader (and its workers) alive past `del loader`
            loss, n = run.step_loss(net, batch, run.dev)
            if loss is not None:
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                state.row_loss += float(loss.detach()) * n
                state.row_count += n
            state.step += 1
            state.patches += n
            state.row_patches += n
            state.row_seconds += time.monotonic() - t0
            state.seconds = run_seconds0 + (time.monotonic() - run_start)
            if state.step % row_steps == 0 or state.step == total:
                row = _row(run, lr, row_steps)
                atomic_write_bytes(csv_path, _csv_bytes(state.rows), fsync=False)
                if bar is not None:
                    v = row["val_loss"]
                    bar.set_postfix_str(f"loss {row['train_loss']:.4f}"
                                        + (f", val {v:.4f}" if v != "" else "")
                                        + f", {row['patches_per_s']:.0f} patches/s")
            if bar is not None:
                if cfg.steps is not None:
                    bar.update(1)
                else:
                    bar.update(int(state.seconds) - bar.n) if int(state.seconds) > bar.n else None
            if time.monotonic() - last_ckpt >= 60.0 * checkpoint_minutes:
                save_checkpoint(ckpt_path, cfg, run.sources, net, opt, state, finished=False)
                last_ckpt = time.monotonic()
        if stop["signal"]:
            save_checkpoint(ckpt_path, cfg, run.sources, net, opt, state, finished=False)
            raise TrainInterrupted(f"interrupted ({stop['signal']}) at step {state.step}: "
                                   f"checkpoint {ckpt_path} written; continue with the same "
                                   "command and --resume")
    finally:
        del loader  # stops the worker processes
        if bar is not None:
            bar.close()
        for sig, old in handlers.items():
            signal.signal(sig, old)


def _finish(run: _Run, *, row_steps: int) -> TrainResult:
    """The last partial row, the default aggregation chosen on the validation pairs, the model
    header; the CSV, the last checkpoint and the model file written."""
    cfg, state, net = run.cfg, run.state, run.net
    model_path, csv_path, ckpt_path = run.paths
    if state.row_count:  # a last partial row
        _row(run, run.opt.param_groups[0]["lr"], row_steps)
    check_learned(cfg, steps=state.step, patches=state.patches, start_clock=run.start_clock)
    net.eval()
    model = LearnedModel(net=net, header={})
    aggregate, bads = choose_aggregate(model, run.sources, run.dev)
    last = state.rows[-1] if state.rows else {}
    header = {
        "inference": {"aggregate": aggregate, "lr_check": False, "subpixel": True,
                      "aggregate_chosen_on": f"bad-3 of {min(SELECT_PAIRS, run.n_val)} "
                                             f"validation pairs over {list(AGGREGATES)}: {bads}"},
        "training": {"sources": [s.header() for s in run.sources], "steps": state.step,
                     "patches": state.patches, "seconds": round(state.seconds, 1),
                     "seed": cfg.seed, "minutes": cfg.minutes, "max_steps": cfg.steps,
                     "crops": cfg.crops, "crop": cfg.crop, "lr": cfg.lr, "device": str(run.dev),
                     "batch": {"crops": cfg.crops, "crop": cfg.crop, "workers": run.workers,
                               "step": "one pass" if run.one_pass else "crop by crop"},
                     "torch": str(torch.__version__), "threads": torch.get_num_threads(),
                     "train_loss": last.get("train_loss"), "val_loss": last.get("val_loss")},
    }
    atomic_write_bytes(csv_path, _csv_bytes(state.rows), fsync=False)
    save_checkpoint(ckpt_path, cfg, run.sources, net, run.opt, state, finished=True)
    atomic_write_bytes(model_path, model_bytes(net, header))
    val = last.get("val_loss")
    return TrainResult(model=model_path, csv=csv_path, checkpoint=ckpt_path, steps=state.step,
                       patches=state.patches, seconds=time.monotonic() - run.start_clock,
                       train_loss=float(last.get("train_loss", float("nan"))),
                       val_loss=None if val in (None, "") else float(val),
                       aggregate=aggregate, rows=state.rows)
