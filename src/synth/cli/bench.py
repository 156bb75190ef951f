"""``stereoforge bench``: speed tables (Markdown and CSV) naming the machine they ran on."""

from __future__ import annotations

from pathlib import Path

import click

from synth.cli.options import (LazyChoice, address_option, backend_option, engine_option, fail,
                               out_dir_option)
from synth.formats import DEFAULT_FORMAT

__all__ = ["bench"]


def _worker_counts(text: str) -> list[int]:
    """``--workers 1,2`` -> [1, 2]; anything else is one Error line."""
    parts = [w.strip() for w in text.split(",") if w.strip()]
    if not parts or not all(p.isdigit() and int(p) > 0 for p in parts):
        fail(ValueError(f"--workers must be positive ints separated by commas, got {text!r}"))
    return [int(p) for p in parts]


@click.group()
def bench() -> None:
    """Benchmarks: print a table and write it (Markdown and CSV) under --out."""


@bench.command("render")
@out_dir_option(default="out/bench")
@click.option("--pairs", default=20, show_default=True, type=click.IntRange(min=1),
              help="Pairs rendered per preset and size.")
@click.option("--sizes", default="640x480,1280x960", show_default=True)
@backend_option
@click.option("--threads", default="0", show_default=True,
              help="llvmpipe rasterizer threads: 0 renders in the calling thread (one core, "
                   "as each dataset worker does); 'auto' keeps the driver's one per core.")
def bench_render_cmd(out, pairs, sizes, backend, threads) -> None:
    """Pairs per second for every preset: render + GT + masks + writing, one process."""
    from synth.jobs.bench.render import bench_render, parse_sizes, write_table

    if threads == "auto":
        n_threads = None
    elif threads.isdigit():
        n_threads = int(threads)
    else:
        fail(ValueError(f"--threads must be 'auto' or an int >= 0, got {threads!r}"))
    rows = bench_render(sizes=parse_sizes(sizes), pairs=pairs, backend=backend,
                        threads=n_threads, progress=True)
    click.echo(write_table(rows, Path(out), "render"))


@bench.command("match")
@out_dir_option(default="out/bench")
@click.option("--repeats", default=3, show_default=True, type=click.IntRange(min=1))
@click.option("--isa", default="native", show_default=True,
              type=LazyChoice("synth.jobs.bench.match:ISAS"),
              help="avx2: also time an AVX2-only numba build (a fresh process) beside this CPU's.")
@click.option("--matcher", "matchers", multiple=True, metavar="MATCHER",
              help="Also time this MATCHER string (NAME[:WINDOW], learned:MODEL.pt, py:..., "
                   "cmd:...); repeatable.")
def bench_match_cmd(out, repeats, isa, matchers) -> None:
    """Census matchers against OpenCV StereoBM / StereoSGBM on the same pairs, same run."""
    from synth.jobs.bench.match import bench_match_isas, peak_memory
    from synth.jobs.bench.render import write_table

    rows = bench_match_isas(isa, repeats=repeats, matchers=matchers)
    click.echo(write_table(rows, Path(out), "match"))
    memory = []
    for method, aggregate, lr_check in (("ct", None, False), ("ct", 5, True), ("sct", None, False)):
        m = peak_memory(width=1280, height=960, max_disparity=256, window=21, method=method,
                        aggregate=aggregate, lr_check=lr_check)
        memory.append({"case": f"{method.upper()} 21x21, 1280x960, D=256"
                               + (f", aggregate {aggregate}, LR check" if aggregate else ""),
                       **m, "target_mb": 1024})
    for spec in matchers:
        for width, height, n_disp in ((640, 480, 64), (1280, 960, 256)):
            m = peak_memory(width=width, height=height, max_disparity=n_disp, matcher=spec)
            memory.append({"case": f"{spec}, {width}x{height}, D={n_disp}", **m,
                           "target_mb": 1024})
    click.echo(write_table(memory, Path(out), "match-memory"))


@bench.command("paper")
@out_dir_option(default="out/bench")
def bench_paper_cmd(out) -> None:
    """The paper's methods (CTHW, AWCT, AWSCT) against CT/SCT at the same window, same run."""
    from synth.jobs.bench.paper import bench_paper_methods
    from synth.jobs.bench.render import write_table

    click.echo(write_table(bench_paper_methods(), Path(out), "paper"))


@bench.command("dataset")
@out_dir_option(default="out/bench")
@click.option("--count", default=40, show_default=True, type=click.IntRange(min=1))
@click.option("--configs", default="planes,texture-sweep,flying", show_default=True,
              help="Comma-separated example names or config paths; a name listed twice is "
                   "run twice (the second run finds the worker server started).")
@click.option("--workers", "workers_text", default="1,2", show_default=True,
              help="Comma-separated worker counts; efficiency is relative to the first.")
@click.option("--size", "size_text", default=None, metavar="WxH",
              help="Render at this size instead of each config's (e.g. 960x540, FlyingThings3D's).")
@click.option("--format", "formats_text", default=DEFAULT_FORMAT, show_default=True,
              help="Comma-separated layouts to write, each measured in the same run (e.g. "
                   "middlebury,sceneflow,crestereo,fsd).")
@click.option("--image-deflate", "deflates_text", default=None, metavar="NAMES",
              help="Comma-separated deflates of the images' PNGs (the configurations' "
                   "image_deflate: isal, libdeflate, zlib, stored), each measured in the same "
                   "run; default: each configuration's own.")
@backend_option
@engine_option
@address_option
def bench_dataset_cmd(out, count, configs, workers_text, size_text, formats_text, deflates_text,
                      backend, engine, address) -> None:
    """Dataset pairs/s with 1 and 2 workers (writing included), scaling, time for 35,454 pairs.

    With --engine ray: a local Ray on 127.0.0.1 per run, or the cluster at --address; the actors
    return the samples and this process commits them, as stereoforge dataset does (the
    driver_cpu_ms_per_pair column)."""
    from synth.jobs.bench.dataset import bench_dataset
    from synth.jobs.bench.render import parse_sizes, write_table

    names = [c.strip() for c in configs.split(",") if c.strip()]
    if not names:
        fail(ValueError("--configs is empty; give example names such as planes,flying"))
    workers = _worker_counts(workers_text)
    sizes = parse_sizes(size_text) if size_text is not None else [None]
    if len(sizes) != 1:
        fail(ValueError(f"--size takes one WxH, got {size_text!r}"))
    from synth.formats import DATASET_FORMATS

    formats = [f.strip() for f in formats_text.split(",") if f.strip()]
    unknown = [f for f in formats if f not in DATASET_FORMATS]
    if not formats or unknown:
        fail(ValueError(f"--format: expected layouts among {', '.join(DATASET_FORMATS)}, got "
                        f"{formats_text!r}"))
    from matcher.io import DEFLATES

    deflates: list[str | None] = [None]  # each configuration's own
    if deflates_text is not None:
        deflates = [d.strip() for d in deflates_text.split(",") if d.strip()]
        if not deflates or not set(deflates) <= set(DEFLATES):
            fail(ValueError(f"--image-deflate: expected names among {', '.join(DEFLATES)}, got "
                            f"{deflates_text!r}"))
    rows = bench_dataset(configs=names, count=count, workers=workers,
                         backend=backend, progress=True, size=sizes[0], engine=engine,
                         address=address, formats=formats, image_deflates=deflates)
    click.echo(write_table(rows, Path(out), "dataset"))
    from synth.jobs.bench.dataset import profile_dataset

    # where one worker's time goes, per stage (docs/scale.md builds its estimates on it)
    stages = [profile_dataset(name, count=count, backend=backend, size=sizes[0],
                              image_deflate=deflate)
              for name in dict.fromkeys(names) for deflate in deflates]
    click.echo(write_table(stages, Path(out), "dataset-stages"))


@bench.command("realism")
@out_dir_option(default="out/bench")
@click.option("--config", default="flying", show_default=True,
              help="Dataset config (example name or TOML path) whose pairs are compared.")
@click.option("--count", default=20, show_default=True, type=click.IntRange(min=1))
@click.option("--data", default=None,
              help="Middlebury folder with third/ (default $STEREOFORGE_MIDDLEBURY or "
                   "../shared/data/middlebury); without it only Motorcycle is the reference.")
@click.option("--workers", default=1, show_default=True, type=click.IntRange(min=1))
@click.option("--tolerance", default=5.0, show_default=True, type=click.FloatRange(min=0),
              help="Points of bad-3 the synthetic mean may differ from the real one.")
@click.option("--matchers", default=None,
              help="Comma-separated MATCHER strings compared (default ct:9,ct:21,sgbm:5).")
@click.option("--real", "real", multiple=True, metavar="SPEC",
              help="A real set scored and ranked too (repeatable; validate --real's SPECs: "
                   "eth3d:DIR, drivingstereo:DIR, kitti:DIR, ...).")
@backend_option
def bench_realism_cmd(out, config, count, data, workers, tolerance, matchers, real,
                      backend) -> None:
    """bad-3 of CT-9, CT-21 and SGBM-5 (or --matchers) on synthetic pairs against real scenes."""
    import os

    from synth.jobs.bench.realism import bench_realism, format_verdict
    from synth.jobs.bench.render import write_table

    folder = Path(data or os.environ.get("STEREOFORGE_MIDDLEBURY") or "../shared/data/middlebury")
    if data is not None and not (folder / "third").is_dir():
        fail(FileNotFoundError(f"--data: no third/ folder under {folder}; pass the Middlebury "
                               f"folder holding third/<Scene>/"))
    result = bench_realism(config=config, count=count,
                           data=folder if (folder / "third").is_dir() else None,
                           out=Path(out), workers=workers, backend=backend, tolerance=tolerance,
                           matchers=None if matchers is None else [
                               m for m in matchers.split(",") if m.strip()],
                           real=real, log=lambda m: click.echo(m, err=True))
    click.echo(write_table(result.summary, Path(out), "realism"))
    write_table(result.samples, Path(out), "realism-samples")
    if result.agreement:
        click.echo(write_table(result.agreement, Path(out), "realism-agreement"))
    click.echo(format_verdict(result, tolerance=tolerance))


@bench.command("validate")
@out_dir_option(default="out/bench")
@click.option("--matcher", default="ct:9", show_default=True, help="MATCHER string validated.")
@click.option("--suite", default="quick", show_default=True, type=click.Choice(["quick", "full"]))
@click.option("--against", default="ct:9,sgbm:5", show_default=True)
@click.option("--workers", "workers_text", default="1,2", show_default=True,
              help="Comma-separated worker counts, one run each.")
@click.option("--repeats", default=1, show_default=True, type=click.IntRange(min=1))
@backend_option
@click.option("--skip-battery", is_flag=True, hidden=True,
              help="Internal: time pairs and matching only.")
def bench_validate_cmd(out, matcher, suite, against, workers_text, repeats, backend,
                       skip_battery) -> None:
    """Seconds of a whole `validate` run from an empty folder (quick suite target: 120 s)."""
    from synth.jobs.bench.render import write_table
    from synth.jobs.bench.validate import bench_validate

    workers = _worker_counts(workers_text)
    rows = bench_validate(matcher=matcher, suite=suite,
                          against=[a.strip() for a in against.split(",") if a.strip()],
                          workers=workers, repeats=repeats, backend=backend,
                          battery=not skip_battery, progress=True)
    click.echo(write_table(rows, Path(out), "validate"))


@bench.command("transfer")
@out_dir_option(default="out/bench")
@click.option("--configs", default="flying,middlebury-like", show_default=True,
              help="Comma-separated dataset configs (example names or TOML paths) to train on.")
@click.option("--count", default=200, show_default=True, type=click.IntRange(min=1),
              help="Pairs rendered per config.")
@click.option("--minutes", default=None, type=click.FloatRange(min=0.05),
              help="Training budget of every model (wall time, data loading included; "
                   "default 10 unless --steps).")
@click.option("--steps", default=None, type=click.IntRange(min=1),
              help="Training budget of every model in steps instead of --minutes: the same "
                   "work for every model however busy the machine is.")
@click.option("--seeds", "seeds_text", default="0", show_default=True,
              help="Comma-separated seeds: one model per config and seed.")
@click.option("--data", default=None,
              help="Middlebury folder with third/ (default $STEREOFORGE_MIDDLEBURY or "
                   "../shared/data/middlebury); without it only Motorcycle is scored.")
@click.option("--workers", default=2, show_default=True, type=click.IntRange(min=1),
              help="Rendering workers.")
@click.option("--device", default="auto", show_default=True, help="auto, cpu or cuda[:N].")
@click.option("--no-ceiling", is_flag=True,
              help="Skip the in-domain ceiling (leave-one-scene-out on the real scenes).")
@click.option("--aggregate", default=None, type=click.IntRange(min=1),
              help="Score every learned model with this box side (1: none). Default: each "
                   "chooses its box on pairs it did not train on (the real-scene models on a "
                   "validation scene).")
@click.option("--real", "real", multiple=True, metavar="SPEC",
              help="A real set every model is scored on too, by the field's metric (repeatable; "
                   "validate --real's SPECs: eth3d:DIR, drivingstereo:DIR, kitti:DIR, ...).")
def bench_transfer_cmd(out, configs, count, minutes, steps, seeds_text, data, workers, device,
                       no_ceiling, aggregate, real) -> None:
    """Train the reference network on each config, score it on real scenes beside CT and SGBM."""
    import os

    from synth.jobs.bench.render import write_table
    from synth.jobs.bench.transfer import bench_transfer, draw_transfer
    from synth.jobs.bench.machine import describe_machine

    seeds = [s.strip() for s in seeds_text.split(",") if s.strip()]
    if not seeds or not all(s.isdigit() for s in seeds):
        fail(ValueError(f"--seeds must be integers >= 0 separated by commas, got {seeds_text!r}"))
    if minutes is not None and steps is not None:
        fail(ValueError("--minutes and --steps are two budgets for the same training; give one"))
    minutes = 10.0 if minutes is None else minutes
    folder = Path(data or os.environ.get("STEREOFORGE_MIDDLEBURY") or "../shared/data/middlebury")
    if data is not None and not (folder / "third").is_dir():
        fail(FileNotFoundError(f"--data: no third/ folder under {folder}; pass the Middlebury "
                               "folder holding third/<Scene>/"))
    result = bench_transfer(configs=[c.strip() for c in configs.split(",")],
                            count=count, minutes=minutes, steps=steps,
                            seeds=[int(s) for s in seeds],
                            data=folder if (folder / "third").is_dir() else None, out=Path(out),
                            workers=workers, device=device, ceiling=not no_ceiling,
                            aggregate=aggregate, real=real,
                            log=lambda m: click.echo(m, err=True))
    click.echo(f"post-processing: {result.post_processing}")
    click.echo(write_table(result.summary, Path(out), "transfer"))
    if result.gap:
        click.echo(write_table(result.gap, Path(out), "transfer-gap"))
    write_table(result.rows, Path(out), "transfer-scenes")
    if result.real_rows:
        write_table(result.real_rows, Path(out), "transfer-real")
    write_table(result.models, Path(out), "transfer-models")
    from matcher.learned import resolve_device

    machine = describe_machine(backend=None)
    device = f"{device} ({resolve_device(device)})" if device == "auto" else device
    boxes = f"all at {aggregate}x{aggregate}" if aggregate else "each chose its box on held-out pairs"
    budget = f"{minutes:g} min" if steps is None else f"{steps} steps"
    title = (f"bad-3 per real scene; models trained {budget} each on {count} pairs "
             f"({len(seeds)} seed(s), range bars), {boxes}, device {device};\n{machine.cpu}, "
             f"{machine.cores} cores, numba {machine.numba_target}")
    click.echo(f"figure: {draw_transfer(result, Path(out) / 'transfer.png', title=title)}")
