"""``stereoforge match`` and ``eval``: run a matcher, score a disparity map."""

from __future__ import annotations

import json
from pathlib import Path

import click

from synth.cli.options import fail, method_option, note

__all__ = ["eval_cmd", "eval_dataset_cmd", "match_cmd"]


@click.command("match")
@click.argument("left", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("right", type=click.Path(dir_okay=False, path_type=Path))
@method_option
@click.option("--window", default=9, show_default=True, type=int,
              help="Odd window size (the largest window for awct/awsct).")
@click.option("--max-disp", "max_disp", default=64, show_default=True, type=int,
              help="Number of disparities searched: d = 0 .. max-disp - 1.")
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Disparity map to write (.pfm, inf where invalid).")
@click.option("--lr-check", is_flag=True, help="Left-right consistency check (failures become inf).")
@click.option("--subpixel", is_flag=True, help="Parabola subpixel refinement.")
@click.option("--aggregate", default=None, type=int, help="Box aggregation window (default: none).")
@click.option("--matcher", "matcher_spec", default=None, metavar="MATCHER",
              help="Any MATCHER string instead of --method/--window/...: ct:9, sgbm:5, "
                   "learned:MODEL.pt, py:FILE.py:FUNCTION, cmd:TEMPLATE.")
def match_cmd(left, right, method, window, max_disp, out, lr_check, subpixel, aggregate,
              matcher_spec) -> None:
    """Match LEFT and RIGHT images and write the left disparity map to --out."""
    from matcher import match
    from matcher.io import read_image, write_pfm
    from synth.jobs.bench.timing import first_and_warm
    from synth._util.kernel_cache import MATCHER_KERNELS, compile_notice

    if out.suffix.lower() != ".pfm":
        fail(ValueError(f"--out must be a .pfm file (got {out.name})"))
    if matcher_spec is not None:
        ctx = click.get_current_context()
        given = [f"--{n.replace('_', '-')}" for n in ("method", "window", "lr_check", "subpixel",
                                                      "aggregate")
                 if ctx.get_parameter_source(n) is click.core.ParameterSource.COMMANDLINE]
        if given:
            fail(ValueError(f"--matcher names the whole matcher; drop {', '.join(given)} (a "
                            "learned model's steps are in its header; override them in Python "
                            "with matcher.learned.match_learned)"))
        _match_any(left, right, matcher_spec, max_disp, out)
        return
    left_img, right_img = read_image(left), read_image(right)
    with compile_notice(MATCHER_KERNELS, note):
        timed = first_and_warm(lambda: match(
            left_img, right_img, method=method, window=window, max_disparity=max_disp,
            lr_check=lr_check, subpixel=subpixel, aggregate=aggregate))
    result = timed.result
    write_pfm(out, result.disparity)  # atomic: a failure leaves a previous file intact
    invalid = 100.0 * float((~(result.disparity < float("inf"))).mean())
    click.echo(f"{method} {window}x{window} D={max_disp}: {timed.describe()}, "
               f"invalid {invalid:.2f} %, wrote {out}")
    if result.ops is not None:
        click.echo(f"operations: {result.ops}")


def _match_any(left: Path, right: Path, spec: str, max_disp: int, out: Path) -> None:
    """``match --matcher``: one MATCHER string on a pair, timed warm like the built-ins."""
    from matcher.adapters import resolve_matcher
    from matcher.io import read_image, write_pfm
    from synth.jobs.bench.timing import first_and_warm

    m = resolve_matcher(spec)  # a bad string or model file fails before the images are read
    left_img, right_img = read_image(left), read_image(right)
    try:
        timed = first_and_warm(lambda: m(left_img, right_img, max_disparity=max_disp))
    finally:
        m.close()
    disparity = timed.result
    write_pfm(out, disparity)
    invalid = 100.0 * float((~(disparity < float("inf"))).mean())
    click.echo(f"{m.name} D={max_disp}: {timed.describe()}, invalid {invalid:.2f} %, wrote {out}")


@click.command("eval")
@click.argument("disp", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("gt", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--gt-divisor", default=None, type=float,
              help="Divide an 8/16-bit PNG ground truth by this (e.g. 3 for Middlebury third size).")
@click.option("--disp-divisor", default=None, type=float, help="Same, for a PNG estimate.")
@click.option("--mask", default=None, type=click.Path(dir_okay=False, path_type=Path),
              help="Occlusion mask PNG, grey (255 = non-occluded); adds the nonocc region.")
@click.option("--delta", default=3.0, show_default=True, type=float, help="PoBMP error threshold (px).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
@click.option("--benchmark", "benchmark", default=None,
              type=click.Choice(["middlebury", "kitti", "eth3d", "all"]),
              help="Score as that benchmark's own code does (MiddEval3 evaldisp, KITTI 2015 devkit, "
                   "ETH3D two-view), each figure labelled with its convention; 'all' prints the three.")
@click.option("--obj-map", "obj_map", default=None, type=click.Path(dir_okay=False, path_type=Path),
              help="KITTI obj_map PNG, grey (0 = background): splits --benchmark kitti into "
                   "bg/fg.")
@click.option("--ndisp", default=None, type=int,
              help="calib.txt's ndisp for --benchmark middlebury (estimates are clipped to it).")
def eval_cmd(disp, gt, gt_divisor, disp_divisor, mask, delta, as_json, benchmark, obj_map,
             ndisp) -> None:
    """Compare an estimated disparity map DISP with the ground truth GT (PFM or PNG)."""
    from synth.jobs.evaluate import BENCHMARKS, evaluate_benchmarks, evaluate_files

    if benchmark is None:
        report = evaluate_files(disp, gt, gt_divisor=gt_divisor, disp_divisor=disp_divisor,
                                mask=mask, delta=delta)
    else:
        report = evaluate_benchmarks(
            disp, gt, benchmarks=BENCHMARKS if benchmark == "all" else (benchmark,),
            gt_divisor=gt_divisor, disp_divisor=disp_divisor, mask=mask, obj_map=obj_map,
            ndisp=ndisp)
    if as_json:
        click.echo(json.dumps(report, indent=2, sort_keys=True))
        return
    if benchmark is not None:
        for label, metrics in report.items():
            click.echo(f"{label}  ({metrics['convention']})")
            click.echo("  " + "  ".join(f"{k}={v:.3f}" if isinstance(v, float) else f"{k}={v}"
                                        for k, v in metrics.items() if k != "convention"))
        return
    keys = list(next(iter(report.values())).keys())
    click.echo("region   " + " ".join(f"{k:>9}" for k in keys))
    for region, metrics in report.items():
        click.echo(f"{region:<8} " + " ".join(f"{metrics[k]:>9.3f}" if isinstance(metrics[k], float)
                                              else f"{metrics[k]:>9}" for k in keys))


@click.command("eval-dataset")
@click.argument("folder", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--matcher", required=True, metavar="MATCHER",
              help="NAME[:WINDOW], learned:MODEL.pt, py:MODULE:FUNCTION, py:FILE.py:FUNCTION or "
                   "cmd:TEMPLATE.")
@click.option("--out", "out", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Output folder (default: FOLDER/eval/<matcher>).")
@click.option("--max-disp", "max_disp", default=None, type=click.IntRange(min=1),
              help="Search range (default: the sample's, else calib.txt's ndisp).")
@click.option("--timeout", default=60.0, show_default=True,
              type=click.FloatRange(min=0.0, min_open=True),
              help="Seconds per pair before a py: or cmd: matcher is killed.")
def eval_dataset_cmd(folder, matcher, out, max_disp, timeout) -> None:
    """Score MATCHER on every sample of FOLDER: a dataset, or a study kept with --keep-pairs."""
    from synth.jobs.eval_dataset import eval_dataset

    path = eval_dataset(folder, matcher=matcher, out=out, max_disparity=max_disp,
                        timeout=timeout)
    click.echo(f"results: {path}")
