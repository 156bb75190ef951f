"""The ``stereoforge`` command line: a thin click layer, one function per subcommand.

Every subcommand parses its options and calls one library function; errors in the input are
reported as ``Error: ...`` with exit status 2 (click's convention for usage errors) and no
traceback.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

__all__ = ["main"]


def _fail(exc: Exception) -> None:
    raise click.UsageError(str(exc)) from exc


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="stereoforge")
def main() -> None:
    """stereoforge: labelled stereo data with exact ground truth, and census matchers."""


# --------------------------------------------------------------------------- scenes / rendering
@main.command()
def presets() -> None:
    """List the built-in scenes with a one-line description each."""
    from scenes import list_presets

    rows = list_presets()
    width = max(len(name) for name, _ in rows)
    for name, description in rows:
        click.echo(f"{name:<{width}}  {description}")


@main.command()
@click.argument("scene", required=False)
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Output directory (must be empty unless --overwrite).")
@click.option("--width", default=640, show_default=True, type=click.IntRange(min=1))
@click.option("--height", default=480, show_default=True, type=click.IntRange(min=1))
@click.option("--fx", default=None, type=float, help="Focal length in pixels [default: 600·width/640].")
@click.option("--baseline", default=0.1, show_default=True, type=float, help="Baseline in metres.")
@click.option("--seed", default=None, type=int, help="Seed of a preset [default: 0].")
@click.option("--format", "fmt", default="middlebury", show_default=True,
              type=click.Choice(["middlebury", "kitti"]))
@click.option("--backend", default="auto", show_default=True,
              type=click.Choice(["auto", "egl", "osmesa"]))
@click.option("--overwrite", is_flag=True, help="Write into a non-empty output directory.")
@click.option("--from-manifest", "from_manifest", nargs=2, default=None,
              type=(click.Path(file_okay=False, path_type=Path), int), metavar="DIR INDEX",
              help="Re-render sample INDEX of the dataset in DIR alone (same bytes), instead of SCENE.")
def render(scene, out, width, height, fx, baseline, seed, fmt, backend, overwrite,
           from_manifest) -> None:
    """Render SCENE (a preset name or a .toml/.json scene file) as a labelled stereo pair."""
    from synth.export import prepare_output_dir, resolve_scene, write_pair
    from synth.pair import render_pair
    from synth.rig import StereoRig

    if from_manifest is not None:
        from synth.dataset import render_from_manifest

        if scene is not None:
            _fail(ValueError("give either SCENE or --from-manifest DIR INDEX, not both"))
        try:
            written = render_from_manifest(from_manifest[0], from_manifest[1], out=out,
                                           overwrite=overwrite, backend=backend)
        except (ValueError, FileNotFoundError) as exc:
            _fail(exc)
        click.echo(f"wrote {len(written)} files to {out}")
        return
    if scene is None:
        _fail(ValueError("missing SCENE (a preset name or a scene file), or --from-manifest DIR INDEX"))
    try:
        spec, seed = resolve_scene(scene, seed=seed)
        rig = StereoRig.default(width, height, fx=fx, baseline=baseline)
        pair = render_pair(spec, rig, backend=backend)  # validates before anything is written
        out = prepare_output_dir(out, overwrite=overwrite)
        written = write_pair(pair, out, scene=spec, seed=seed, fmt=fmt)
    except (ValueError, FileNotFoundError) as exc:
        _fail(exc)
    click.echo(f"wrote {len(written)} files to {out}")


@main.command()
@click.argument("config")
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path))
@click.option("--count", default=None, type=click.IntRange(min=1),
              help="Number of pairs [default: the config's count].")
@click.option("--workers", default=1, show_default=True, type=click.IntRange(min=1))
@click.option("--engine", default="local", show_default=True, type=click.Choice(["local", "ray"]))
@click.option("--address", default=None, help="Ray cluster address (engine ray); default: local.")
@click.option("--format", "fmt", default="middlebury", show_default=True,
              type=click.Choice(["middlebury", "kitti"]))
@click.option("--backend", default="auto", show_default=True,
              type=click.Choice(["auto", "egl", "osmesa"]))
def dataset(config, out, count, workers, engine, address, fmt, backend) -> None:
    """Generate a labelled dataset from CONFIG (a .toml file or a shipped example name).

    Deterministic (same config, same bytes, whatever the worker count) and resumable: rerun the
    same command after an interruption and it finishes the missing samples.
    """
    if engine == "local" and workers > 1:  # the worker server imports while this process does
        from synth.engine import start_worker_server

        start_worker_server(["synth.dataset"])  # the task's module (the server adds its own)
    from synth.dataset import SampleError, run_dataset

    try:
        run = run_dataset(config, out=out, count=count, workers=workers, engine=engine,
                          address=address, fmt=fmt, progress=True, backend=backend)
    except (ValueError, FileNotFoundError) as exc:
        _fail(exc)
    except SampleError as exc:  # a sample failed: name it and how to reproduce it alone
        raise click.ClickException(str(exc)) from exc
    click.echo(f"{run.count} samples in {run.out}: {run.rendered} rendered, {run.skipped} already "
               f"there, {run.seconds:.1f} s")


@main.command()
@click.option("--out", "out", default="out/demo", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--width", default=320, show_default=True, type=click.IntRange(min=16))
@click.option("--height", default=240, show_default=True, type=click.IntRange(min=16))
@click.option("--seed", default=0, show_default=True, type=int)
@click.option("--backend", default="auto", show_default=True,
              type=click.Choice(["auto", "egl", "osmesa"]))
@click.option("--overwrite", is_flag=True, help="Write into a non-empty output directory.")
def demo(out, width, height, seed, backend, overwrite) -> None:
    """Render every preset into OUT/<preset>/ and draw OUT/contact_sheet.png."""
    from synth.demo import run_demo

    try:
        sheet = run_demo(out, width=width, height=height, seed=seed, backend=backend,
                         overwrite=overwrite, progress=True)
    except ValueError as exc:
        _fail(exc)
    click.echo(f"contact sheet: {sheet}")


# --------------------------------------------------------------------------- matching
@main.command("match")
@click.argument("left", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("right", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--method", default="ct", show_default=True,
              type=click.Choice(["ct", "sct", "cthw", "awct", "awsct", "bm", "sgbm"]))
@click.option("--window", default=9, show_default=True, type=int,
              help="Odd window size (the largest window for awct/awsct).")
@click.option("--max-disp", "max_disp", default=64, show_default=True, type=int,
              help="Number of disparities searched: d = 0 .. max-disp - 1.")
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Disparity map to write (.pfm, inf where invalid).")
@click.option("--lr-check", is_flag=True, help="Left-right consistency check (failures become inf).")
@click.option("--subpixel", is_flag=True, help="Parabola subpixel refinement.")
@click.option("--aggregate", default=None, type=int, help="Box aggregation window (default: none).")
def match_cmd(left, right, method, window, max_disp, out, lr_check, subpixel, aggregate) -> None:
    """Match LEFT and RIGHT images and write the left disparity map to --out."""
    import time

    from matcher import match
    from matcher.io import read_image, write_pfm

    try:
        left_img, right_img = read_image(left), read_image(right)
        t0 = time.perf_counter()
        result = match(left_img, right_img, method=method, window=window, max_disparity=max_disp,
                       lr_check=lr_check, subpixel=subpixel, aggregate=aggregate)
        seconds = time.perf_counter() - t0
        if out.suffix.lower() != ".pfm":
            raise ValueError(f"--out must be a .pfm file (got {out.name})")
        write_pfm(out, result.disparity)
    except (ValueError, FileNotFoundError, TypeError) as exc:
        _fail(exc)
    invalid = 100.0 * float((~(result.disparity < float("inf"))).mean())
    click.echo(f"{method} {window}x{window} D={max_disp}: {seconds * 1e3:.1f} ms, "
               f"invalid {invalid:.2f} %, wrote {out}")
    if result.ops is not None:
        click.echo(f"operations: {result.ops}")


@main.command("eval")
@click.argument("disp", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("gt", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--gt-divisor", default=None, type=float,
              help="Divide an 8/16-bit PNG ground truth by this (e.g. 3 for Middlebury third size).")
@click.option("--disp-divisor", default=None, type=float, help="Same, for a PNG estimate.")
@click.option("--mask", default=None, type=click.Path(dir_okay=False, path_type=Path),
              help="Occlusion mask PNG (255 = non-occluded); adds the nonocc region.")
@click.option("--delta", default=3.0, show_default=True, type=float, help="PoBMP error threshold (px).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
def eval_cmd(disp, gt, gt_divisor, disp_divisor, mask, delta, as_json) -> None:
    """Compare an estimated disparity map DISP with the ground truth GT (PFM or PNG)."""
    from synth.evaluate import evaluate_files

    try:
        report = evaluate_files(disp, gt, gt_divisor=gt_divisor, disp_divisor=disp_divisor,
                                mask=mask, delta=delta)
    except (ValueError, FileNotFoundError) as exc:
        _fail(exc)
    if as_json:
        click.echo(json.dumps(report, indent=2, sort_keys=True))
        return
    keys = list(next(iter(report.values())).keys())
    click.echo("region   " + " ".join(f"{k:>9}" for k in keys))
    for region, metrics in report.items():
        click.echo(f"{region:<8} " + " ".join(f"{metrics[k]:>9.3f}" if isinstance(metrics[k], float)
                                              else f"{metrics[k]:>9}" for k in keys))


@main.command()
@click.option("--data", "data", default="../shared/data/middlebury", show_default=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="Middlebury folder holding third/ and half/ scene folders.")
@click.option("--size", default="third", show_default=True, type=click.Choice(["third", "half"]))
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path))
def paper(data, size, out) -> None:
    """Reproduce the seed paper's Tables 1-3 and figures on the real Middlebury scenes."""
    from synth.paper import run_paper

    if not (data / size).is_dir():
        _fail(FileNotFoundError(
            f"no {size}/ folder under {data}; pass --data pointing at the Middlebury scenes"))
    try:
        report = run_paper(data, size=size, out=out, progress=True)
    except (ValueError, FileNotFoundError) as exc:
        _fail(exc)
    click.echo(f"report: {report}")


@main.command()
@click.argument("config")
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path))
@click.option("--workers", default=1, show_default=True, type=click.IntRange(min=1))
@click.option("--backend", default="auto", show_default=True,
              type=click.Choice(["auto", "egl", "osmesa"]))
def study(config, out, workers, backend) -> None:
    """Texture frequency x window x method study from CONFIG (a .toml file or a shipped name).

    Resumable: rerun the same command and only the missing cells are computed.
    """
    if workers > 1:  # the worker server imports while this process does
        from synth.engine import start_worker_server

        start_worker_server(["synth.study"])
    from synth.study import run_study

    try:
        path = run_study(config, out=out, workers=workers, progress=True, backend=backend)
    except (ValueError, FileNotFoundError) as exc:
        _fail(exc)
    click.echo(f"results: {path / 'results.csv'}, summary: {path / 'summary.md'}")


@main.group()
def golden() -> None:
    """Golden references: exact matcher outputs and tolerant render checks (golden/)."""


@golden.command("check")
@click.option("--root", default="golden", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--render/--no-render", default=True, show_default=True,
              help="Also re-render the golden scenes (needs GL) and compare within tolerances.")
@click.option("--backend", default="auto", show_default=True,
              type=click.Choice(["auto", "egl", "osmesa"]))
def golden_check_cmd(root, render, backend) -> None:
    """Compare fresh matcher outputs (exactly) and renders (within tolerances) with golden/."""
    from synth.golden import golden_check

    try:
        report = golden_check(root, backend=backend, render=render)
    except (ValueError, FileNotFoundError) as exc:
        _fail(exc)
    click.echo(report.summary())
    if not report.ok:
        raise SystemExit(1)


@golden.command("update")
@click.option("--root", default="golden", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--backend", default="auto", show_default=True,
              type=click.Choice(["auto", "egl", "osmesa"]))
def golden_update_cmd(root, backend) -> None:
    """Regenerate golden/ and print what changed."""
    from synth.golden import format_changes, golden_update

    click.echo(format_changes(golden_update(root, backend=backend)))


# --------------------------------------------------------------------------- benchmarks
@main.group()
def bench() -> None:
    """Benchmarks: print a table and write it (Markdown and CSV) under --out."""


@bench.command("render")
@click.option("--out", "out", default="out/bench", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--pairs", default=20, show_default=True, type=click.IntRange(min=1),
              help="Pairs rendered per preset and size.")
@click.option("--sizes", default="640x480,1280x960", show_default=True)
@click.option("--backend", default="auto", show_default=True,
              type=click.Choice(["auto", "egl", "osmesa"]))
@click.option("--threads", default="0", show_default=True,
              help="llvmpipe rasterizer threads: 0 renders in the calling thread (one core, "
                   "as each dataset worker does); 'auto' keeps the driver's one per core.")
def bench_render_cmd(out, pairs, sizes, backend, threads) -> None:
    """Pairs per second for every preset: render + GT + masks + writing, one process."""
    from synth.bench import bench_render, parse_sizes, write_table

    if threads == "auto":
        n_threads = None
    elif threads.isdigit():
        n_threads = int(threads)
    else:
        _fail(ValueError(f"--threads must be 'auto' or an int >= 0, got {threads!r}"))
    try:
        rows = bench_render(sizes=parse_sizes(sizes), pairs=pairs, backend=backend,
                            threads=n_threads, progress=True)
    except ValueError as exc:
        _fail(exc)
    click.echo(write_table(rows, Path(out), "render"))


@bench.command("match")
@click.option("--out", "out", default="out/bench", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--repeats", default=3, show_default=True, type=click.IntRange(min=1))
def bench_match_cmd(out, repeats) -> None:
    """Census matchers against OpenCV StereoBM / StereoSGBM on the same pairs, same run."""
    from matcher.bench import bench_match, peak_memory
    from synth.bench import write_table

    rows = bench_match(repeats=repeats)
    click.echo(write_table(rows, Path(out), "match"))
    memory = []
    for method, aggregate, lr_check in (("ct", None, False), ("ct", 5, True), ("sct", None, False)):
        m = peak_memory(width=1280, height=960, max_disparity=256, window=21, method=method,
                        aggregate=aggregate, lr_check=lr_check)
        memory.append({"case": f"{method.upper()} 21x21, 1280x960, D=256"
                               + (f", aggregate {aggregate}, LR check" if aggregate else ""),
                       **m, "target_mb": 1024})
    click.echo(write_table(memory, Path(out), "match-memory"))


@bench.command("paper")
@click.option("--out", "out", default="out/bench", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
def bench_paper_cmd(out) -> None:
    """The paper's methods (CTHW, AWCT, AWSCT) against CT/SCT at the same window, same run."""
    from matcher.bench_paper import bench_paper_methods
    from synth.bench import write_table

    click.echo(write_table(bench_paper_methods(), Path(out), "paper"))


@bench.command("dataset")
@click.option("--out", "out", default="out/bench", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--count", default=40, show_default=True, type=click.IntRange(min=1))
@click.option("--configs", default="planes,texture-sweep,flying", show_default=True,
              help="Comma-separated example names or config paths; a name listed twice is "
                   "run twice (the second run finds the worker server started).")
@click.option("--workers", "workers_text", default="1,2", show_default=True,
              help="Comma-separated worker counts; efficiency is relative to the first.")
@click.option("--backend", default="auto", show_default=True,
              type=click.Choice(["auto", "egl", "osmesa"]))
def bench_dataset_cmd(out, count, configs, workers_text, backend) -> None:
    """Dataset pairs/s at 640x480 with 1 and 2 workers (writing included) and scaling."""
    from synth.bench import write_table
    from synth.bench_dataset import bench_dataset

    names = [c.strip() for c in configs.split(",") if c.strip()]
    parts = [w.strip() for w in workers_text.split(",") if w.strip()]
    if not names:
        _fail(ValueError("--configs is empty; give example names such as planes,flying"))
    if not parts or not all(p.isdigit() and int(p) > 0 for p in parts):
        _fail(ValueError(f"--workers must be positive ints separated by commas, got "
                         f"{workers_text!r}"))
    try:
        rows = bench_dataset(configs=names, count=count, workers=[int(p) for p in parts],
                             backend=backend, progress=True)
    except (ValueError, FileNotFoundError) as exc:
        _fail(exc)
    click.echo(write_table(rows, Path(out), "dataset"))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
