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
:func:`matcher.learned.network.check_architecture`, the crop and the network's halo against the
smallest image). A failure in a ``DataLoader`` worker (a corrupt sample) comes back to this
process as a value and ends the run with one error naming the sample and its file; the workers
stop, and the last checkpoint stays as it was. Memory that cannot be had ends it with
:class:`TrainOutOfMemory` (how much, and for what). A run that learned nothing (no step, or no
patch in any crop) writes no model.
"""

from __future__ import annotations

import csv
import io
import math
import os
import signal
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch

from matcher.io import atomic_write_bytes
from matcher.io.atomic import claim_output
from matcher.learned import (
    Architecture,
    PatchNet,
    batch_pair_scores,
    hinge_loss,
    match_learned,
    model_bytes,
    pair_scores,
    resolve_device,
)
from matcher.learned.model import LearnedModel
from stereoforge.errors import DatasetError, ParameterError, StereoforgeError
from synth.jobs.train.checks import (TrainOutOfMemory, check_learned, check_options, check_sizes,
                                     out_of_memory)
from synth.jobs.train.patches import (CROP, CROPS, Crop, Failed, GuardedBatches, LoaderFailure,
                                      PatchBatches)
from synth.jobs.train.sources import TrainPair, TrainSource, open_sources

__all__ = ["AGGREGATES", "CSV_COLUMNS", "GPU_CROPS", "ROW_STEPS", "TrainConfig",
           "TrainInterrupted", "TrainOutOfMemory", "TrainResult", "aggregate_bad3",
           "default_crops", "train"]

#: Steps per CSV row (and per validation loss).
ROW_STEPS = 100
#: Validation batches the validation loss averages over.
VAL_BATCHES = 8
#: Box sides (1 = none) tried for the model's default aggregation.
AGGREGATES = (1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21)
#: Validation pairs the aggregation is chosen on.
SELECT_PAIRS = 4
#: Crops per step by default on a GPU (the CPU's default is :data:`CROPS`): a step of 16 crops
#: is bound by per-step overheads there, not by the GPU.
GPU_CROPS = 256
#: Right strips of a one-pass batch are padded to a multiple of this width (few distinct shapes).
_PAD_WIDTH = 64
CSV_COLUMNS = ("step_from", "step_to", "seconds", "train_loss", "val_loss", "patches",
               "patches_per_s", "lr")
_CKPT_FORMAT = "stereoforge-train-checkpoint"
class TrainInterrupted(StereoforgeError):
    """Ctrl-C or SIGTERM: the checkpoint is written; ``--resume`` continues."""


@dataclass(frozen=True)
class TrainConfig:
    """Everything a run is defined by (what a resumed run must repeat).

    ``minutes`` and ``steps``: exactly one is set. ``lr`` drops tenfold for the last fifth of
    the budget.
    """

    sources: tuple[str, ...]
    out: str
    minutes: float | None = None
    steps: int | None = None
    seed: int = 0
    channels: int = 32
    layers: int = 4
    crops: int = CROPS
    crop: int = CROP
    lr: float = 1e-3
    val_fraction: float = 0.1

    def identity(self) -> dict:
        """What a checkpoint must match to be resumed (the output path aside)."""
        d = asdict(self)
        d.pop("out")
        d["sources"] = list(d["sources"])
        return d


@dataclass(frozen=True)
class TrainResult:
    """What a run made."""

    model: Path
    csv: Path
    checkpoint: Path
    steps: int
    patches: int
    seconds: float
    train_loss: float
    val_loss: float | None
    aggregate: int
    rows: list = field(default_factory=list)


def _identity_collate(batch):
    return batch


def _worker_init(_worker_id: int) -> None:
    # Ctrl-C and SIGTERM are the main process's to handle: it stops after the step in
    # progress, writes the checkpoint and shuts the workers down
    from synth.dataset.engine.tasks import die_with_parent

    die_with_parent()  # a killed trainer leaves no worker behind
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def _right_tensors(crop: Crop, device: torch.device) -> tuple:
    """A crop's right strip (1, 1, h, w) and its patches' rows, columns, positives, negatives."""
    t = lambda a: torch.from_numpy(np.ascontiguousarray(a)).to(device)  # noqa: E731
    return t(crop.right)[None, None], t(crop.ys), t(crop.xs), t(crop.x_pos), t(crop.x_neg)


def _batch_loss(net: PatchNet, batch: list[Crop], device: torch.device
                ) -> tuple[torch.Tensor | None, int]:
    """Mean hinge loss over every patch of a batch, and the number of patches."""
    if not batch:
        return None, 0
    lefts = torch.cat([torch.from_numpy(np.ascontiguousarray(c.left))[None, None]
                       for c in batch]).to(device)
    fl = net(lefts)  # every left block has the same size: one pass
    pos, neg = [], []
    for i, crop in enumerate(batch):
        right, ys, xs, xp, xn = _right_tensors(crop, device)
        sp, sn = pair_scores(fl[i], net(right)[0], ys, xs, xp, xn)
        pos.append(sp)
        neg.append(sn)
    s_pos, s_neg = torch.cat(pos), torch.cat(neg)
    return hinge_loss(s_pos, s_neg), int(s_pos.numel())


def _one_pass_loss(net: PatchNet, batch: list[Crop], device: torch.device
                   ) -> tuple[torch.Tensor | None, int]:
    """:func:`_batch_loss` with the whole batch in two passes of the network (the lefts, then
    the right strips padded to one width) and every patch's positive and negative sampled at
    once on the device (:func:`matcher.learned.batch_pair_scores`): no per-crop step, which is
    what bounds a GPU. Equal to :func:`_batch_loss` up to float rounding."""
    if not batch:
        return None, 0
    r = net.arch.layers
    widths = [c.right.shape[1] for c in batch]
    width = -(-max(widths) // _PAD_WIDTH) * _PAD_WIDTH
    rights = np.zeros((len(batch), 1, batch[0].right.shape[0], width), np.float32)
    for i, crop in enumerate(batch):
        rights[i, 0, :, :widths[i]] = crop.right
    lefts = np.stack([c.left for c in batch])[:, None]
    counts = [c.ys.size for c in batch]
    index = np.repeat(np.arange(len(batch)), counts)
    last = np.repeat(np.asarray(widths) - 2 * r - 1, counts)
    pin = device.type == "cuda"
    t = lambda a: (torch.from_numpy(np.ascontiguousarray(a)).pin_memory() if pin  # noqa: E731
                   else torch.from_numpy(np.ascontiguousarray(a))).to(device, non_blocking=pin)
    cat = np.concatenate
    s_pos, s_neg = batch_pair_scores(
        net(t(lefts)), net(t(rights)), t(index), t(cat([c.ys for c in batch])),
        t(cat([c.xs for c in batch])), t(cat([c.x_pos for c in batch])),
        t(cat([c.x_neg for c in batch])), t(last))
    return hinge_loss(s_pos, s_neg), int(s_pos.numel())


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


@dataclass
class _State:
    """What a checkpoint holds besides the weights and the optimiser."""

    step: int = 0
    seconds: float = 0.0
    patches: int = 0
    rows: list = field(default_factory=list)
    row_loss: float = 0.0
    row_count: int = 0
    row_patches: int = 0
    row_seconds: float = 0.0


def _save_checkpoint(path: Path, cfg: TrainConfig, sources: list[TrainSource], net: PatchNet,
                     opt: torch.optim.Optimizer, state: _State, finished: bool) -> None:
    buf = io.BytesIO()
    torch.save({"format": _CKPT_FORMAT, "version": 1, "config": cfg.identity(),
                "sources": [s.header() for s in sources], "state": asdict(state),
                "finished": finished,
                "net": {k: v.detach().to("cpu") for k, v in net.state_dict().items()},
                "opt": opt.state_dict()}, buf)
    atomic_write_bytes(path, buf.getvalue())


def _load_checkpoint(path: Path, cfg: TrainConfig, sources: list[TrainSource]) -> dict:
    if not path.is_file():
        raise DatasetError(f"--resume: no checkpoint {path}; start without --resume")
    try:
        blob = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - any unreadable archive
        raise DatasetError(f"{path}: not a readable checkpoint ({type(exc).__name__}); remove "
                           "it and start again without --resume") from None
    if not isinstance(blob, dict) or blob.get("format") != _CKPT_FORMAT:
        raise DatasetError(f"{path}: not a stereoforge training checkpoint; remove it and start "
                           "again without --resume")
    want, got = cfg.identity(), blob.get("config", {})
    diff = [k for k in want if want[k] != got.get(k)]
    if diff:
        k = diff[0]
        raise DatasetError(f"--resume: the checkpoint {path} was made with {k} = {got.get(k)!r}, "
                           f"this run asks for {want[k]!r}; repeat the first run's options")
    hashes = [(s["spec"], s["hash"]) for s in blob.get("sources", [])]
    if hashes != [(s.spec, s.hash) for s in sources]:
        raise DatasetError(f"--resume: the training data changed since the checkpoint {path} "
                           "(another hash); start again without --resume")
    return blob


def _val_loss(net: PatchNet, batches: list[list[Crop]], device: torch.device,
              step_loss: Callable = _batch_loss) -> float | None:
    if not batches:
        return None
    total, count = 0.0, 0
    with torch.no_grad():
        for batch in batches:
            loss, n = step_loss(net, batch, device)
            if loss is not None:
                total += float(loss) * n
                count += n
    return total / count if count else None


def _search_range(disp: np.ndarray, visible: np.ndarray, width: int) -> int:
    top = float(disp[visible].max()) if visible.any() else 16.0
    return int(min(width - 1, max(4, 4 * math.ceil(math.ceil(1.1 * top + 1) / 4))))


def aggregate_bad3(model: LearnedModel, pair: TrainPair, device: str | torch.device = "cpu"
                   ) -> np.ndarray:
    """bad-3 (%, all pixels with ground truth, no estimate = bad) of ``model`` on one pair with
    each box side of :data:`AGGREGATES` (sub-pixel on, no left-right check), in that order."""
    from matcher.cost import aggregate_cost
    from matcher.learned import learned_cost
    from matcher.select import winner_takes_all

    known = pair.disp > 0
    cost = learned_cost(model, pair.left, pair.right, device=device,
                        max_disparity=_search_range(pair.disp, known, pair.left.shape[1]))
    bad = np.zeros(len(AGGREGATES))
    for a, size in enumerate(AGGREGATES):
        vol = cost if size == 1 else aggregate_cost(cost, size=size)
        est = winner_takes_all(vol, subpixel=True)
        err = np.abs(est - pair.disp)[known]
        bad[a] = 100.0 * float(np.mean(~(err <= 3.0)))
    return bad


def _choose_aggregate(model: LearnedModel, sources: list[TrainSource], device: torch.device
                      ) -> tuple[int, list]:
    """The box side of :data:`AGGREGATES` with the smallest bad-3 (:func:`aggregate_bad3`) over
    up to :data:`SELECT_PAIRS` validation pairs; 5 without any."""
    pairs = [(s, i) for s in sources for i in range(s.n_val)][:SELECT_PAIRS]
    if not pairs:
        return 5, []
    bad = np.zeros(len(AGGREGATES))
    for s, i in pairs:
        bad += aggregate_bad3(model, s.load("val", i), device)
    bad /= len(pairs)
    return int(AGGREGATES[int(np.argmin(bad))]), [round(float(b), 3) for b in bad]


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
    if not model_path.parent.is_dir():
        raise FileNotFoundError(f"--out: the folder {model_path.parent} does not exist; create it")
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


def _train_claimed(cfg: TrainConfig, start_clock: float, say: Callable[[str], None], *,
                   device: str, resume: bool, workers: int, threads: int | None,
                   checkpoint_minutes: float, show_progress: bool, row_steps: int,
                   one_pass: bool | None) -> TrainResult:
    """:func:`train` once this process holds the output's lock."""
    model_path, csv_path, ckpt_path = _paths(cfg.out)
    dev = resolve_device(device)
    one_pass = dev.type != "cpu" if one_pass is None else bool(one_pass)
    step_loss = _one_pass_loss if one_pass else _batch_loss
    sources = open_sources(cfg.sources, val_fraction=cfg.val_fraction)
    for note in (n for s in sources for n in s.notes):
        say(note)
    check_sizes(cfg, sources)
    blob = _load_checkpoint(ckpt_path, cfg, sources) if resume else None
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
    arch = Architecture(channels=cfg.channels, layers=cfg.layers)
    net = PatchNet(arch).to(dev)
    opt = torch.optim.Adam(net.parameters(), lr=cfg.lr)
    state = _State()
    if blob is not None:
        net.load_state_dict(blob["net"])
        opt.load_state_dict(blob["opt"])
        state = _State(**blob["state"])
        say(f"resuming {ckpt_path} at step {state.step} ({state.seconds:.0f} s trained)")
    n_train = sum(s.n_train for s in sources)
    n_val = sum(s.n_val for s in sources)
    say(f"training on {n_train} pairs ({', '.join(s.name for s in sources)}), validating on "
        f"{n_val}; {arch.channels} maps x {arch.layers} layers ({arch.patch}x{arch.patch} "
        f"patches), {cfg.crops} crops of {cfg.crop}x{cfg.crop} per step"
        f"{' in one pass' if one_pass else ''}, device {dev}")

    total = cfg.steps if cfg.steps is not None else 10**12
    budget = None if cfg.minutes is None else 60.0 * cfg.minutes
    batches = PatchBatches(sources, seed=cfg.seed, radius=arch.layers, crops=cfg.crops,
                           size=cfg.crop)
    val = PatchBatches(sources, seed=cfg.seed, radius=arch.layers, split="val",
                       crops=cfg.crops, size=cfg.crop)
    t_val = time.monotonic()
    val_batches = [val[i] for i in range(VAL_BATCHES)] if val.pairs else []
    say(f"{len(val_batches)} validation batches cut in {time.monotonic() - t_val:.1f} s")

    stop = {"signal": None}
    handlers = {}

    def on_signal(signum, _frame):
        stop["signal"] = signal.Signals(signum).name

    import threading

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
        loader = iter(_loader(batches, state.step, total, workers)) if state.step < total else iter(())
        while state.step < total:
            elapsed = run_seconds0 + (time.monotonic() - run_start)
            if budget is not None and (time.monotonic() - start_clock) + run_seconds0 >= budget:
                break
            if stop["signal"]:
                break
            progress_share = (state.step / total) if cfg.steps is not None else elapsed / budget
            lr = cfg.lr * (0.1 if progress_share >= 0.8 else 1.0)
            for group in opt.param_groups:
                group["lr"] = lr
            t0 = time.monotonic()
            failure = None
            try:
                batch = next(loader)
            except Exception as exc:  # noqa: BLE001 - the loader's own (a worker killed, ...)
                failure = LoaderFailure(f"the data loader failed at step {state.step}: "
                                         f"{' '.join(str(exc).split())[:300]}")
            if failure is not None:  # raised here, outside the handler: no traceback keeps
                raise failure        # the loader (and its workers) alive
            if isinstance(batch, Failed):
                raise batch.error
            loss, n = step_loss(net, batch, dev)
            if loss is not None:
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                state.row_loss += float(loss.detach()) * n
                state.row_count += n
            state.step += 1
            state.patches += n
            state.row_patches += n
            dt = time.monotonic() - t0
            state.row_seconds += dt
            state.seconds = run_seconds0 + (time.monotonic() - run_start)
            if state.step % row_steps == 0 or state.step == total:
                v = _val_loss(net, val_batches, dev, step_loss)
                row = {"step_from": state.step - (state.step - 1) % row_steps,
                       "step_to": state.step, "seconds": round(state.seconds, 2),
                       "train_loss": round(state.row_loss / max(state.row_count, 1), 6),
                       "val_loss": "" if v is None else round(v, 6),
                       "patches": state.patches,
                       "patches_per_s": round(state.row_patches / max(state.row_seconds, 1e-9), 1),
                       "lr": lr}
                state.rows.append(row)
                state.row_loss, state.row_count, state.row_patches, state.row_seconds = 0.0, 0, 0, 0.0
                atomic_write_bytes(csv_path, _csv_bytes(state.rows), fsync=False)
                if bar is not None:
                    bar.set_postfix_str(f"loss {row['train_loss']:.4f}"
                                        + (f", val {v:.4f}" if v is not None else "")
                                        + f", {row['patches_per_s']:.0f} patches/s")
            if bar is not None:
                if cfg.steps is not None:
                    bar.update(1)
                else:
                    bar.update(int(state.seconds) - bar.n) if int(state.seconds) > bar.n else None
            if time.monotonic() - last_ckpt >= 60.0 * checkpoint_minutes:
                _save_checkpoint(ckpt_path, cfg, sources, net, opt, state, finished=False)
                last_ckpt = time.monotonic()
        if stop["signal"]:
            _save_checkpoint(ckpt_path, cfg, sources, net, opt, state, finished=False)
            raise TrainInterrupted(f"interrupted ({stop['signal']}) at step {state.step}: "
                                   f"checkpoint {ckpt_path} written; continue with the same "
                                   "command and --resume")
    finally:
        del loader  # stops the worker processes
        if bar is not None:
            bar.close()
        for sig, old in handlers.items():
            signal.signal(sig, old)

    if state.row_count:  # a last partial row
        v = _val_loss(net, val_batches, dev, step_loss)
        state.rows.append({"step_from": state.step - (state.step - 1) % row_steps,
                           "step_to": state.step, "seconds": round(state.seconds, 2),
                           "train_loss": round(state.row_loss / state.row_count, 6),
                           "val_loss": "" if v is None else round(v, 6), "patches": state.patches,
                           "patches_per_s": round(state.row_patches / max(state.row_seconds, 1e-9), 1),
                           "lr": opt.param_groups[0]["lr"]})
        state.row_loss, state.row_count, state.row_patches, state.row_seconds = 0.0, 0, 0, 0.0
    check_learned(cfg, steps=state.step, patches=state.patches, start_clock=start_clock)
    net.eval()
    model = LearnedModel(net=net, header={})
    aggregate, bads = _choose_aggregate(model, sources, dev)
    last = state.rows[-1] if state.rows else {}
    header = {
        "inference": {"aggregate": aggregate, "lr_check": False, "subpixel": True,
                      "aggregate_chosen_on": f"bad-3 of {min(SELECT_PAIRS, n_val)} validation "
                                             f"pairs over {list(AGGREGATES)}: {bads}"},
        "training": {"sources": [s.header() for s in sources], "steps": state.step,
                     "patches": state.patches, "seconds": round(state.seconds, 1),
                     "seed": cfg.seed, "minutes": cfg.minutes, "max_steps": cfg.steps,
                     "crops": cfg.crops, "crop": cfg.crop, "lr": cfg.lr, "device": str(dev),
                     "batch": {"crops": cfg.crops, "crop": cfg.crop, "workers": workers,
                               "step": "one pass" if one_pass else "crop by crop"},
                     "torch": str(torch.__version__), "threads": torch.get_num_threads(),
                     "train_loss": last.get("train_loss"), "val_loss": last.get("val_loss")},
    }
    atomic_write_bytes(csv_path, _csv_bytes(state.rows), fsync=False)
    _save_checkpoint(ckpt_path, cfg, sources, net, opt, state, finished=True)
    atomic_write_bytes(model_path, model_bytes(net, header))
    val_loss = last.get("val_loss")
    return TrainResult(model=model_path, csv=csv_path, checkpoint=ckpt_path, steps=state.step,
                       patches=state.patches, seconds=time.monotonic() - start_clock,
                       train_loss=float(last.get("train_loss", float("nan"))),
                       val_loss=None if val_loss in (None, "") else float(val_loss),
                       aggregate=aggregate, rows=state.rows)
