"""``stereoforge validate``: stress any matcher on controlled axes and write one report."""

from __future__ import annotations

import click

from synth.cli.options import backend_option, out_dir_option, workers_option

__all__ = ["validate", "against_option", "timeout_option"]


def against_option(f):
    """``--against``: comma-separated reference MATCHER strings."""
    return click.option("--against", default="ct:9,sgbm:5", show_default=True,
                        help="Reference MATCHER strings, comma-separated, run on the same pairs "
                             "('' for none).")(f)


def timeout_option(f):
    """``--timeout``: seconds per pair for py: and cmd: matchers."""
    return click.option("--timeout", default=60.0, show_default=True,
                        type=click.FloatRange(min=0.0, min_open=True),
                        help="Seconds per pair before a py: or cmd: matcher is killed.")(f)


def split_against(text: str) -> list[str]:
    return [a.strip() for a in text.split(",") if a.strip()]


@click.command()
@click.argument("matcher")
@out_dir_option()
@click.option("--suite", default="quick", show_default=True, type=click.Choice(["quick", "full"]))
@against_option
@workers_option
@timeout_option
@click.option("--axes", default=None, metavar="A,B,...",
              help="Only these axes, comma-separated (default: every axis; see docs/validate.md).")
@click.option("--real", "real", multiple=True, metavar="SPEC",
              help="Real scenes scored beside the axes (repeatable): middlebury:DIR[:DIVISOR], "
                   "kitti:DIR[:FIRST-LAST] or skimage:motorcycle.")
@click.option("--fail-on", "fail_on", default=None, type=click.Choice(["properties"]),
              help="Exit with status 1 when a required property fails.")
@backend_option
@click.option("--skip-battery", is_flag=True, hidden=True,
              help="Internal: pairs, estimates and results.csv only (no properties, no report).")
def validate(matcher, out, suite, against, workers, timeout, axes, real, fail_on, backend,
             skip_battery) -> None:
    """Validate MATCHER (NAME[:WINDOW], py:MODULE:FUNCTION, py:FILE.py:FUNCTION or
    cmd:TEMPLATE) on every axis of the suite, against the references, into --out.

    Resumable: rerun the same command and only missing or damaged work is redone.
    """
    if workers > 1:  # the worker server imports while this process does
        from synth.dataset.engine import start_worker_server

        start_worker_server(["synth.validate.run", "synth.validate.pairs", "synth.pair"])
    from synth.cli.options import fail
    from synth.validate.axes import AXES
    from synth.validate.run import run_validate

    chosen = None if axes is None else split_against(axes)
    unknown = [a for a in chosen or () if a not in AXES]
    if chosen is not None and (unknown or not chosen):
        what = f"unknown axis {unknown[0]!r}" if unknown else "no axis given"
        fail(ValueError(f"--axes: {what}; axes: {', '.join(AXES)}"))

    res = run_validate(matcher, out=out, suite=suite, against=split_against(against),
                       workers=workers, timeout=timeout, backend=backend, progress=True,
                       axes=chosen, battery=not skip_battery, real=real)
    click.echo(f"pairs: {res.pairs_rendered} rendered, {res.pairs_reused} reused; estimates: "
               f"{res.estimates_computed} computed, {res.estimates_reused} reused; "
               f"{res.seconds['total']:.1f} s")
    click.echo(f"results: {res.results}")
    if res.battery_ran:
        click.echo(f"properties: {out / 'properties.json'}, report: {out / 'report.html'}")
        if res.failed_properties:
            click.echo(f"required properties failed: {', '.join(res.failed_properties)}")
            if fail_on == "properties":
                raise SystemExit(1)
