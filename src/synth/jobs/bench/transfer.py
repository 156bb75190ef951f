"""Does the data teach? ``stereoforge bench transfer``: the reference network trained with one
budget on each dataset config, scored on real scenes it never saw, beside census and SGBM.

For every config (default ``flying`` and ``middlebury-like``) the job renders ``count`` pairs
into ``out/pairs/<config>`` (the dataset engine resumes a partial folder), then trains one model
per seed with ``stereoforge train ... --minutes M --seed S`` (or ``--steps N``: the same number
of steps for every model, whatever else the machine is doing) in a process of its own (wall time
measured, data loading included; a model already in ``out/models`` trained with the same budget
is reused). The in-domain
ceiling is the same network trained on the real scenes themselves, leave-one-scene-out: one
model per held-out scene and seed, scored on the held-out scene.

The ceiling is fair, at matched post-processing, in one of two ways (the table says which):

- ``aggregate=None`` (default): every model chooses its box aggregation on pairs it did not
  train on: a model of our data on its dataset's validation split (the choice in its header),
  a real-scene model on a validation scene, the scene after the held-out one (so it trains on
  the other scenes but those two; :func:`synth.jobs.train.aggregate_bad3` picks the box);
- ``aggregate=N``: every learned model is scored with an ``N x N`` box (1: none), and the
  real-scene models train on all scenes but the held-out one.

:attr:`TransferResult.gap` gives, per config and seed, ours minus real-trained: mean bad-3 over
the scenes of the model of our data minus that of the real-scene models of the same seed (each
on the scene it did not see), and the mean and range over the seeds.

``real`` (``--real SPEC``, repeatable: ``validate --real``'s SPECs, e.g. ``eth3d:DIR``,
``drivingstereo:DIR``, ``kitti:DIR``) adds real sets that every model and reference is scored on
(the ceiling's models each on every scene of them), by the metric the field reports for the set
(:data:`synth.formats.METRICS`: ETH3D bad-1 on non-occluded pixels, Middlebury bad-2, KITTI and
DrivingStereo D1): one column per set in the summary, rows per scene in
:attr:`TransferResult.real_rows`.

Real scenes: the six Middlebury 2005/2006 scenes of ``--data`` at third size (search range
0..83, disparity = ``disp1.png / 3``) and scikit-image's Motorcycle (Middlebury 2014, 0..63),
read as ``stereoforge validate --real`` reads them (:mod:`synth.validate.real`: ground truth,
and the non-occluded pixels from a left-right check of the two ground truths, or the left one
warped to the right view). Measures over all pixels with ground truth (``all``) and over the
non-occluded ones (``nonocc``): bad-2 and bad-3 (a missing estimate counts bad) and avgerr (over
the estimates). Matchers: each model through :func:`matcher.learned.match_learned` (the
left-right check and sub-pixel steps of its header, the aggregation above), CT-9, CT-21 (census
WTA) and SGBM-5 (:func:`matcher.match` defaults).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
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
    """Per-scene rows, per-method summary rows (with a column per ``--real`` set), the models
    trained, the gap ours minus real-trained per config and seed (:func:`_gap`), how the boxes
    were chosen, and the ``--real`` sets' per-scene rows."""

    rows: list[dict]
    summary: list[dict]
    models: list[dict]
    gap: list[dict] = field(default_factory=list)
    post_processing: str = ""
    #: Per-scene rows of the ``--real`` sets: method, trained_on, seed, set, scene, metric, value.
    real_rows: list[dict] = field(default_factory=list)


def _real_specs(data: Path | None) -> list[tuple[str, int]]:
    """The real scenes (SPECs) the models are scored on, each with its search range."""
    specs = [(f"middlebury:{data / 'third' / s}:3", _THIRD_RANGE) for s in _SCENES] \
        if data is not None else []
    return [*specs, ("skimage:motorcycle", _MOTORCYCLE_RANGE)]


def _scenes(specs: Sequence[tuple[str, int]]) -> list[dict]:
    from synth.validate.real import resolve_real

    out = []
    for spec, max_disparity in specs:
        (scene,) = resolve_real([spec])
        left, right, gt, mask, _ = scene.load()
        out.append({"name": scene.ref.name, "spec": spec, "left": left, "right": right, "gt": gt,
                    "mask": mask, "max_disparity": max_disparity})
    return out


def _real_sets(specs: Sequence[str]) -> list[dict]:
    """The scenes of the ``--real`` SPECs, each with its set (one per SPEC, named by its
    scheme: ``eth3d``, ``drivingstereo``, ``eth3d-2`` for a second) and the set's field metric
    (:data:`synth.formats.METRICS`); the search range as ``validate`` takes it."""
    from synth.formats import METRICS, get_layout
    from synth.validate.pairs import max_disparity_for
    from synth.validate.real import resolve_real, set_names

    out = []
    for name, spec in zip(set_names(specs), specs):
        for scene in resolve_real([spec]):
            left, right, gt, mask, _ = scene.load()
            out.append({"set": name, "name": scene.ref.name, "scene": scene.scene, "left": left,
                        "right": right, "gt": gt, "mask": mask,
                        "metric": METRICS[get_layout(scene.ref.layout).metric],
                        "max_disparity": max_disparity_for(gt, gt.shape[1])})
    return out


def _field_score(estimate: np.ndarray, scene: dict) -> float:
    """The set's field metric (a percentage) of ``estimate`` on a ``--real`` scene."""
    from matcher import evaluate

    metric = scene["metric"]
    m = evaluate(estimate, scene["gt"], delta=3.0, region=metric.region,
                 occlusion_mask=scene["mask"])
    return round(float(getattr(m, metric.field)), 3)


def _real_columns(summary: list[dict], real_rows: list[dict]) -> None:
    """Each ``--real`` set's column in the summary: ``<set> <metric>``, the mean over its scenes
    per seed, then over the seeds."""
    for row in summary:
        for name in dict.fromkeys(r["set"] for r in real_rows):
            mine = [r for r in real_rows if r["method"] == row["method"] and r["set"] == name]
            per_seed: dict = {}
            for r in mine:
                per_seed.setdefault(r["seed"], []).append(r["value"])
            key = f"{name} {mine[0]['metric'] if mine else ''}".strip()
            row[key] = (round(float(np.mean([np.mean(v) for v in per_seed.values()])), 2)
                        if per_seed else "")


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


def _budget(minutes: float, steps: int | None) -> list[str]:
    """``stereoforge train``'s budget arguments."""
    return ["--minutes", f"{minutes:g}"] if steps is None else ["--steps", str(steps)]


def _train(sources: Sequence[str], model: Path, minutes: float, seed: int, device: str,
           say: Callable[[str], None], steps: int | None = None) -> dict:
    """One ``stereoforge train`` process (it dies with this one); reuses a finished model made
    with the same budget (``MODEL.pt.budget``) and the wall time recorded beside it
    (``MODEL.pt.wall``)."""
    wall_file = Path(f"{model}.wall")
    budget = " ".join(_budget(minutes, steps))
    budget_file = Path(f"{model}.budget")
    try:
        same_budget = budget_file.read_text().strip() == budget
    except OSError:  # none: a model from before budgets were recorded (minutes), or from elsewhere
        same_budget = steps is None
    if model.is_file() and same_budget:
        try:
            wall = float(wall_file.read_text())
        except (OSError, ValueError):  # none (a model from elsewhere) or not a number
            wall = None
        say(f"  {model.name}: reused" + (f" (wall {wall:.0f} s)" if wall is not None else ""))
        return {"model": str(model), "wall_s": wall, "reused": True}
    boot = ("from synth.dataset.engine.tasks import die_with_parent; die_with_parent(); "
            "from synth.cli import main; main()")
    cmd = [sys.executable, "-c", boot, "train", *sources,
           "--out", str(model), *_budget(minutes, steps), "--seed", str(seed),
           "--device", device, "--overwrite"]
    t0 = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - t0
    if proc.returncode != 0:
        from stereoforge.errors import DatasetError

        tail = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        raise DatasetError(f"training {model.name} failed: {tail}")
    atomic_write_bytes(wall_file, f"{wall:.1f}\n".encode())
    atomic_write_bytes(budget_file, f"{budget}\n".encode())
    say(f"  {model.name}: {proc.stdout.strip()} (wall {wall:.0f} s)")
    return {"model": str(model), "wall_s": round(wall, 1), "reused": False}


def _config_name(config: str) -> str:
    return Path(config).stem if os.sep in str(config) or str(config).endswith(".toml") \
        else str(config)


def _check_arguments(configs: Sequence[str], *, count: int, minutes: float, seeds: Sequence[int],
                     workers: int, device: str, steps: int | None = None) -> str:
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
    if steps is not None:
        check_int(steps, "--steps", lo=1, hi=10**9)
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
        boxes = sorted({r["aggregate"] for r in mine if r["aggregate"] != ""})
        row["aggregate"] = "/".join(str(a) for a in boxes)
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


def _gap(rows: list[dict], configs: list[str], seeds: Sequence[int]) -> list[dict]:
    """Ours minus real-trained, mean bad-3 over the scenes, per config and seed; then the mean
    and range over the seeds."""
    def mean(method: str, seed: int, key: str) -> float | None:
        v = [r[key] for r in rows if r["method"] == method and r["seed"] == seed]
        return float(np.mean(v)) if v else None

    out = []
    for name in configs:
        gaps = []
        for seed in seeds:
            ours = mean(f"learned on {name}", seed, "bad3_all")
            real = mean(f"learned on {_REAL}", seed, "bad3_all")
            if ours is None or real is None:
                continue
            gaps.append(ours - real)
            out.append({"trained_on": name, "seed": str(seed), "ours_bad3_all": round(ours, 2),
                        "real_bad3_all": round(real, 2), "gap": round(ours - real, 2),
                        "gap_min": "", "gap_max": ""})
        if gaps:
            out.append({"trained_on": name, "seed": f"mean of {len(gaps)}", "ours_bad3_all": "",
                        "real_bad3_all": "", "gap": round(float(np.mean(gaps)), 2),
                        "gap_min": round(min(gaps), 2), "gap_max": round(max(gaps), 2)})
    return out


_REAL = "real scenes, leave-one-out"


def _check_aggregate(aggregate: int | None, n_scenes: int, ceiling: bool) -> None:
    from matcher.learned.model import MAX_AGGREGATE
    from stereoforge.errors import ParameterError

    if aggregate is not None and (isinstance(aggregate, bool) or not isinstance(aggregate, int)
                                  or aggregate < 1 or aggregate > MAX_AGGREGATE
                                  or (aggregate > 1 and aggregate % 2 == 0)):
        raise ParameterError(f"--aggregate: expected 1 (none) or an odd box side 3..{MAX_AGGREGATE}"
                             f", got {aggregate!r}")
    need = 3 if aggregate is None else 2
    if ceiling and n_scenes < need:
        how = ("a held-out scene, a validation scene and one to train on"
               if aggregate is None else "a held-out scene and one to train on")
        raise ParameterError(f"the in-domain ceiling needs {need} real scenes ({how}), found "
                             f"{n_scenes}; pass --data (the Middlebury folder), --aggregate N "
                             "or --no-ceiling")


def bench_transfer(*, configs: Sequence[str] = ("flying", "middlebury-like"), count: int = 200,
                   minutes: float = 10.0, seeds: Sequence[int] = (0,), data: Path | None = None,
                   out: Path, workers: int = 2, device: str = "auto", ceiling: bool = True,
                   aggregate: int | None = None, steps: int | None = None,
                   real: Sequence[str] = (),
                   log: Callable[[str], None] | None = None) -> TransferResult:
    """Train on each config (and the real scenes, leave-one-out), score on the real scenes;
    ``aggregate``: None, each model's box chosen on pairs it did not train on, or one box side
    for every learned model (see the module docstring); ``steps``: every model trains this
    many steps instead of ``minutes`` of wall time.

    Every argument is checked before anything is rendered or trained (:class:`ParameterError`).
    """
    from matcher.adapters import resolve_matcher
    from matcher.learned.device import device_name
    from synth.dataset import load_config, run_dataset

    say = log or (lambda _m: None)
    if importlib.util.find_spec("torch") is None:  # before hours of rendering, not after
        raise ModuleNotFoundError("No module named 'torch'", name="torch")
    device = device_name(_check_arguments(configs, count=count, minutes=minutes, seeds=seeds,
                                          workers=workers, device=device, steps=steps),
                         "--device")
    for config in configs:  # a bad config fails before anything is made or trained
        load_config(config)
    specs = _real_specs(data)
    _check_aggregate(aggregate, len(specs), ceiling)
    scenes = _scenes(specs)
    extra = _real_sets(real)  # a bad SPEC fails here, before anything is rendered
    (out / "models").mkdir(parents=True, exist_ok=True)
    models: list[dict] = []
    names = []
    for config in configs:
        name = _config_name(config)
        names.append(name)
        folder = out / "pairs" / name
        say(f"{count} pairs of {config} ...")
        run_dataset(config, folder, count=count, workers=workers, progress=False)
        for seed in seeds:
            model = out / "models" / f"{name}-seed{seed}.pt"
            info = _train([str(folder)], model, minutes, seed, device, say, steps)
            models.append({**info, "trained_on": name, "seed": seed, "held_out": "",
                           "validated_on": "its validation split"})
    if ceiling:
        say("in-domain ceiling: leave one real scene out ...")
        for seed in seeds:
            for k, scene in enumerate(scenes):
                val = "" if aggregate is not None else scenes[(k + 1) % len(scenes)]["name"]
                others = [s["spec"] for s in scenes if s["name"] not in (scene["name"], val)]
                tag = f"-val-{val}" if val else ""
                model = out / "models" / f"real-without-{scene['name']}{tag}-seed{seed}.pt"
                info = _train(others, model, minutes, seed, device, say, steps)
                models.append({**info, "trained_on": _REAL, "seed": seed,
                               "held_out": scene["name"], "validated_on": val})
    rows: list[dict] = []
    say("scoring on the real scenes ...")
    real_rows: list[dict] = []

    def on_real(method: str, trained_on: str, seed: int, estimate: Callable) -> None:
        for scene in extra:
            est = estimate(scene)
            real_rows.append({"method": method, "trained_on": trained_on, "seed": seed,
                              "set": scene["set"], "scene": scene["scene"],
                              "metric": scene["metric"].name, "value": _field_score(est, scene)})

    for label, spec in REFERENCES:
        m = resolve_matcher(spec)
        for scene in scenes:
            est = m(scene["left"], scene["right"], max_disparity=scene["max_disparity"])
            rows.append({"method": label, "trained_on": "", "seed": 0, "scene": scene["name"],
                         "aggregate": "", **_score(est, scene)})
        on_real(label, "", 0, lambda sc, m=m: m(sc["left"], sc["right"],
                                                max_disparity=sc["max_disparity"]))
    from matcher.learned import load_model, match_learned
    from synth.jobs.train import AGGREGATES, aggregate_bad3, open_source

    for info in models:
        model = load_model(info["model"])
        training = model.header.get("training")
        training = training if isinstance(training, dict) else {}  # a model from elsewhere
        info.update(steps=training.get("steps"), patches=training.get("patches"),
                    train_s=training.get("seconds"), train_loss=training.get("train_loss"),
                    val_loss=training.get("val_loss"))
        if aggregate is not None:
            agg = aggregate
        elif info["validated_on"] and info["trained_on"] == _REAL:
            spec = next(s["spec"] for s in scenes if s["name"] == info["validated_on"])
            bad = aggregate_bad3(model, open_source(spec).load("train", 0), device)
            agg = int(AGGREGATES[int(np.argmin(bad))])
        else:
            agg = int(model.inference["aggregate"])
        info["aggregate"] = agg
        label = f"learned on {info['trained_on']}"
        for scene in scenes:
            if info["held_out"] and scene["name"] != info["held_out"]:
                continue
            est = match_learned(scene["left"], scene["right"], model, aggregate=agg,
                                max_disparity=scene["max_disparity"], device=device).disparity
            rows.append({"method": label, "trained_on": info["trained_on"], "seed": info["seed"],
                         "scene": scene["name"], "aggregate": agg, **_score(est, scene)})
        on_real(label, info["trained_on"], info["seed"], lambda sc, model=model, agg=agg: (
            match_learned(sc["left"], sc["right"], model, aggregate=agg,
                          max_disparity=sc["max_disparity"], device=device).disparity))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    how = (f"every learned model at {aggregate}x{aggregate}" if aggregate is not None else
           "every learned model's aggregation chosen on pairs it did not train on (ours: their "
           "validation split; real scenes: the scene after the held-out one)")
    summary = _summary(rows, methods)
    for row in summary:  # the table says how each row's box was chosen
        row["box_from"] = ("" if not row["trained_on"] else "fixed" if aggregate is not None
                           else "a validation scene" if row["trained_on"] == _REAL
                           else "its validation split")
    _real_columns(summary, real_rows)
    return TransferResult(rows, summary, models, _gap(rows, names, seeds), how, real_rows)


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
