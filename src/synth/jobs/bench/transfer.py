"""Does the data teach? ``stereoforge bench transfer``: the reference network trained with one
budget on each dataset config, scored on real scenes it never saw, beside census and SGBM.

For every config (default ``flying`` and ``middlebury-like``) the job renders ``count`` pairs
into ``out/pairs/<config>`` (the dataset engine resumes a partial folder), then trains one model
per seed with ``stereoforge train ... --minutes M --seed S`` in a process of its own (wall time
measured, data loading included; a model already in ``out/models`` is reused). The in-domain
ceiling is the same network trained on the real scenes themselves, leave-one-scene-out: one
model per held-out scene on all the others (seed 0), scored on the held-out one.

Real scenes: the six Middlebury 2005/2006 scenes of ``--data`` at third size (search range
0..83, disparity = ``disp1.png / 3``) and scikit-image's Motorcycle (Middlebury 2014, 0..63),
read as ``stereoforge validate --real`` reads them (:mod:`synth.validate.real`: ground truth,
and the non-occluded pixels from a left-right check of the two ground truths, or the left one
warped to the right view). Measures over all pixels with ground truth (``all``) and over the
non-occluded ones (``nonocc``): bad-2 and bad-3 (a missing estimate counts bad) and avgerr (over
the estimates). Matchers: each model as ``learned:MODEL`` (the inference steps of its header),
CT-9, CT-21 (census WTA) and SGBM-5 (:func:`matcher.match` defaults).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from matcher.io.atomic import atomic_write_bytes

__all__ = ["REFERENCES", "TransferResult", "bench_transfer", "draw_transfer"]

#: (label, MATCHER string) of the classical references.
REFERENCES = (("CT-9", "ct:9"), ("CT-21", "ct:21"), ("SGBM-5", "sgbm:5"))
_THIRD_RANGE = 84
_MOTORCYCLE_RANGE = 64
_SCENES = ("Moebius", "Reindeer", "Flowerpots", "Cloth2", "Midd1", "Baby1")


@dataclass(frozen=True)
class TransferResult:
    """Per-scene rows, per-method summary rows and the models trained."""

    rows: list[dict]
    summary: list[dict]
    models: list[dict]


def _real_specs(data: Path | None) -> list[str]:
    specs = [f"middlebury:{data / 'third' / s}:3" for s in _SCENES] if data is not None else []
    return [*specs, "skimage:motorcycle"]


def _scenes(specs: Sequence[str]) -> list[dict]:
    from synth.validate.real import resolve_real

    out = []
    for spec in specs:
        (scene,) = resolve_real([spec])
        left, right, gt, mask, _ = scene.load()
        name = scene.path.rstrip("/").split("/")[-1] if scene.kind != "skimage" else "Motorcycle"
        out.append({"name": name, "spec": spec, "left": left, "right": right, "gt": gt,
                    "mask": mask, "max_disparity": _MOTORCYCLE_RANGE if scene.kind == "skimage"
                    else _THIRD_RANGE})
    return out


def _score(estimate: np.ndarray, scene: dict) -> dict:
    from matcher import evaluate

    row = {}
    for region in ("all", "nonocc"):
        m = evaluate(estimate, scene["gt"], delta=3.0, region=region,
                     occlusion_mask=scene["mask"])
        row[f"bad2_{region}"] = round(m.bad_2, 3)
        row[f"bad3_{region}"] = round(m.pobmp, 3)
        row[f"avgerr_{region}"] = round(m.avgerr, 3)
    return row


def _train(sources: Sequence[str], model: Path, minutes: float, seed: int, device: str,
           say: Callable[[str], None]) -> dict:
    """One ``stereoforge train`` process (it dies with this one); reuses a finished model and
    the wall time recorded beside it (``MODEL.pt.wall``)."""
    wall_file = Path(f"{model}.wall")
    if model.is_file():
        try:
            wall = float(wall_file.read_text())
        except (OSError, ValueError):  # none (a model from elsewhere) or not a number
            wall = None
        say(f"  {model.name}: reused" + (f" (wall {wall:.0f} s)" if wall is not None else ""))
        return {"model": str(model), "wall_s": wall, "reused": True}
    boot = ("from synth.dataset.engine.tasks import die_with_parent; die_with_parent(); "
            "from synth.cli import main; main()")
    cmd = [sys.executable, "-c", boot, "train", *sources,
           "--out", str(model), "--minutes", f"{minutes:g}", "--seed", str(seed),
           "--device", device, "--overwrite"]
    t0 = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - t0
    if proc.returncode != 0:
        from stereoforge.errors import DatasetError

        tail = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        raise DatasetError(f"training {model.name} failed: {tail}")
    atomic_write_bytes(wall_file, f"{wall:.1f}\n".encode())
    say(f"  {model.name}: {proc.stdout.strip()} (wall {wall:.0f} s)")
    return {"model": str(model), "wall_s": round(wall, 1), "reused": False}


def _config_name(config: str) -> str:
    return Path(config).stem if os.sep in str(config) or str(config).endswith(".toml") \
        else str(config)


def _check_arguments(configs: Sequence[str], *, count: int, minutes: float, seeds: Sequence[int],
                     workers: int, device: str) -> str:
    """Refuse bad arguments before any work; the device name."""
    from matcher.learned.device import check_device
    from stereoforge.errors import ParameterError
    from stereoforge.validation import check_int, check_real
    from synth.jobs.train.checks import MAX_MINUTES

    names = [_config_name(c) for c in configs]
    if not names or not all(str(c).strip() for c in configs):
        raise ParameterError(f"--configs: expected dataset configs separated by commas (example "
                             f"names or TOML paths), got {','.join(map(str, configs))!r}")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ParameterError(f"--configs: {', '.join(twice)} comes twice (one folder pairs/<name> "
                             "per config); give each config once")
    check_int(count, "--count", lo=1, hi=10**6)
    check_real(minutes, "--minutes", lo=0, lo_open=True, hi=MAX_MINUTES)
    if not seeds:
        raise ParameterError("--seeds: give at least one seed")
    for seed in seeds:
        check_int(seed, "--seeds", lo=0, hi=2**63 - 1)
    check_int(workers, "--workers", lo=1, hi=256)
    return check_device(device, "--device")


def _summary(rows: list[dict], methods: list[str]) -> list[dict]:
    out = []
    for method in methods:
        mine = [r for r in rows if r["method"] == method]
        if not mine:
            continue
        row = {"method": method, "trained_on": mine[0]["trained_on"]}
        for key in ("bad3_all", "bad2_all", "avgerr_all", "bad3_nonocc", "bad2_nonocc"):
            # mean over scenes per seed, then mean and range over seeds
            per_seed = {}
            for r in mine:
                per_seed.setdefault(r["seed"], []).append(r[key])
            means = [float(np.mean(v)) for v in per_seed.values()]
            row[key] = round(float(np.mean(means)), 2)
            if key == "bad3_all":
                row["bad3_all_min"] = round(min(means), 2)
                row["bad3_all_max"] = round(max(means), 2)
        six = [r for r in mine if r["scene"] != "Motorcycle"]
        if six:
            per_seed = {}
            for r in six:
                per_seed.setdefault(r["seed"], []).append(r["bad3_all"])
            row["bad3_all_six"] = round(float(np.mean([np.mean(v) for v in per_seed.values()])), 2)
        row["seeds"] = len({r["seed"] for r in mine})
        out.append(row)
    return out


def bench_transfer(*, configs: Sequence[str] = ("flying", "middlebury-like"), count: int = 200,
                   minutes: float = 10.0, seeds: Sequence[int] = (0,), data: Path | None = None,
                   out: Path, workers: int = 2, device: str = "auto", ceiling: bool = True,
                   log: Callable[[str], None] | None = None) -> TransferResult:
    """Train on each config (and the real scenes, leave-one-out), score on the real scenes.

    Every argument is checked before anything is rendered or trained (:class:`ParameterError`).
    """
    from matcher.adapters import resolve_matcher
    from synth.dataset import load_config, run_dataset

    say = log or (lambda _m: None)
    if importlib.util.find_spec("torch") is None:  # before hours of rendering, not after
        raise ModuleNotFoundError("No module named 'torch'", name="torch")
    device = _check_arguments(configs, count=count, minutes=minutes, seeds=seeds,
                              workers=workers, device=device)
    for config in configs:  # a bad config fails before anything is made or trained
        load_config(config)
    specs = _real_specs(data)
    scenes = _scenes(specs)
    (out / "models").mkdir(parents=True, exist_ok=True)
    models: list[dict] = []
    for config in configs:
        name = _config_name(config)
        folder = out / "pairs" / name
        say(f"{count} pairs of {config} ...")
        run_dataset(config, folder, count=count, workers=workers, progress=False)
        for seed in seeds:
            model = out / "models" / f"{name}-seed{seed}.pt"
            info = _train([str(folder)], model, minutes, seed, device, say)
            models.append({**info, "trained_on": name, "seed": seed, "held_out": ""})
    if ceiling:
        say("in-domain ceiling: leave one real scene out ...")
        for k, scene in enumerate(scenes):
            others = [s["spec"] for j, s in enumerate(scenes) if j != k]
            model = out / "models" / f"real-without-{scene['name']}.pt"
            info = _train(others, model, minutes, 0, device, say)
            models.append({**info, "trained_on": "real scenes, leave-one-out", "seed": 0,
                           "held_out": scene["name"]})
    rows: list[dict] = []
    say("scoring on the real scenes ...")
    for label, spec in REFERENCES:
        m = resolve_matcher(spec)
        for scene in scenes:
            est = m(scene["left"], scene["right"], max_disparity=scene["max_disparity"])
            rows.append({"method": label, "trained_on": "", "seed": 0, "scene": scene["name"],
                         **_score(est, scene)})
    from matcher.learned import load_model

    for info in models:
        training = load_model(info["model"]).header.get("training")
        training = training if isinstance(training, dict) else {}  # a model from elsewhere
        info.update(steps=training.get("steps"), patches=training.get("patches"),
                    train_s=training.get("seconds"), train_loss=training.get("train_loss"),
                    val_loss=training.get("val_loss"))
        m = resolve_matcher(f"learned:{info['model']}")
        label = f"learned on {info['trained_on']}"
        for scene in scenes:
            if info["held_out"] and scene["name"] != info["held_out"]:
                continue
            est = m(scene["left"], scene["right"], max_disparity=scene["max_disparity"])
            rows.append({"method": label, "trained_on": info["trained_on"], "seed": info["seed"],
                         "scene": scene["name"], **_score(est, scene)})
    methods = list(dict.fromkeys(r["method"] for r in rows))
    return TransferResult(rows, _summary(rows, methods), models)


def draw_transfer(result: TransferResult, path: Path, *, title: str) -> Path:
    """Bar chart of bad-3 (all pixels) per scene: one bar per method (learned: mean over seeds,
    the range as an error bar), a colour legend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from matcher.io import save_figure_atomic

    methods = list(dict.fromkeys(r["method"] for r in result.rows))
    scenes = list(dict.fromkeys(r["scene"] for r in result.rows))
    colours = {"CT-9": "#bdbdbd", "CT-21": "#8c8c8c", "SGBM-5": "#525252"}
    palette = iter(["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf"])
    width = 0.8 / len(methods)
    fig, ax = plt.subplots(figsize=(11, 4.5), dpi=110)
    for i, method in enumerate(methods):
        colour = colours.get(method) or next(palette)
        means, lows, highs = [], [], []
        for scene in scenes:
            v = [r["bad3_all"] for r in result.rows if r["method"] == method and r["scene"] == scene]
            means.append(np.mean(v) if v else np.nan)
            lows.append(np.mean(v) - min(v) if v else 0)
            highs.append(max(v) - np.mean(v) if v else 0)
        x = np.arange(len(scenes)) + (i - (len(methods) - 1) / 2) * width
        ax.bar(x, means, width, color=colour, label=method,
               yerr=[lows, highs] if any(h > 0 for h in highs) else None, capsize=2)
    ax.set_xticks(np.arange(len(scenes)), scenes)
    ax.set_ylabel("bad-3 (%), all pixels with ground truth")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, ncol=3, loc="upper left")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    save_figure_atomic(fig, path)
    plt.close(fig)
    return path
