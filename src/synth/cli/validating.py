"""``stereoforge validate``: stress any matcher on controlled axes and write one report."""

from __future__ import annotations

from pathlib import Path

import click

from synth.cli.options import backend_option, out_dir_option, workers_option

__all__ = ["validate", "against_option", "timeout_option", "FailOn"]

#: ``--fail-on regression`` without POINTS: bad-2 points worse than the baseline.
DEFAULT_REGRESSION_POINTS = 1.0
#: Options that only a run takes (not ``--compare``), with their defaults' sources ignored.
_RUN_ONLY = ("suite", "against", "workers", "timeout", "axes", "backend", "real", "baseline",
             "skip_battery")


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


class FailOn(click.ParamType):
    """``properties``, ``regression`` or ``regression:POINTS`` as ``(what, points or None)``."""

    name = "properties|regression[:POINTS]"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        what, sep, points = str(value).partition(":")
        if what == "properties" and not sep:
            return ("properties", None)
        if what == "regression":
            if not sep:
                return ("regression", DEFAULT_REGRESSION_POINTS)
            try:
                number = float(points)
            except ValueError:
                number = -1.0
            if number >= 0 and number == number and number != float("inf"):
                return ("regression", number)
        self.fail(f"expected properties, regression or regression:POINTS (POINTS a number of "
                  f"bad-2 points >= 0, e.g. regression:2), got {value!r}", param, ctx)


def _regression_lines(rows: list[dict], label: str, where: Path, points: float) -> list[str]:
    from synth.validate.differences import describe_row

    shown = "; ".join(describe_row(r) for r in rows)
    return [f"regression against the {label} ({where}): {len(rows)} axis x region cell(s) worse "
            f"by more than {points:g} bad-2 point(s), 95 % interval above 0: {shown}"]


def _compare(ctx, compare, out, fail_on) -> None:
    from synth.cli.options import fail
    from synth.validate.baseline import compare_runs
    from synth.validate.differences import regressions

    given = [p for p in _RUN_ONLY
             if ctx.get_parameter_source(p) is not click.core.ParameterSource.DEFAULT]
    if given:
        fail(ValueError(f"--compare makes the report of two finished runs; "
                        f"--{given[0].replace('_', '-')} belongs to a run: leave it out"))
    if any(what == "properties" for what, _ in fail_on):
        fail(ValueError("--compare: --fail-on properties belongs to a run; use --fail-on "
                        "regression[:POINTS]"))
    old, new = compare
    label, table = compare_runs(old, new, out)
    click.echo(f"report: {out / 'report.html'}, differences: {out / 'differences.csv'}")
    for _, points in fail_on:
        found = regressions(table, label, points)
        if found:
            for line in _regression_lines(found, label, old, points):
                click.echo(line)
            raise SystemExit(1)


@click.command()
@click.argument("matcher", required=False)
@out_dir_option()
@click.option("--suite", default="quick", show_default=True, type=click.Choice(["quick", "full"]))
@against_option
@workers_option
@timeout_option
@click.option("--axes", default=None, metavar="A,B,...",
              help="Only these axes, comma-separated (default: every axis; see docs/validate.md).")
@click.option("--real", "real", multiple=True, metavar="SPEC",
              help="Real scenes scored beside the axes (repeatable): middlebury:DIR[:DIVISOR], "
                   "kitti:DIR[:FIRST-LAST], eth3d:DIR, drivingstereo:DIR, skimage:motorcycle, "
                   "or a tree of sceneflow:DIR, crestereo:DIR, fsd:DIR.")
@click.option("--baseline", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="A finished validate folder (an earlier version, another matcher): compare "
                   "with its matcher on the same pairs, reusing its pairs and references.")
@click.option("--compare", nargs=2, default=None, metavar="OLD NEW",
              type=click.Path(file_okay=False, path_type=Path),
              help="Make the report of finished run NEW against finished run OLD into --out, "
                   "without matching (no MATCHER then).")
@click.option("--fail-on", "fail_on", multiple=True, type=FailOn(),
              help="Exit with status 1 when a required property fails (properties), or when an "
                   "axis x region is worse than the baseline by more than POINTS bad-2 points "
                   "(default 1) with its 95 % interval above 0 (regression[:POINTS]). "
                   "Repeatable.")
@backend_option
@click.option("--skip-battery", is_flag=True, hidden=True,
              help="Internal: pairs, estimates and results.csv only (no properties, no report).")
@click.pass_context
def validate(ctx, matcher, out, suite, against, workers, timeout, axes, real, baseline,
             compare, fail_on, backend, skip_battery) -> None:
    """Validate MATCHER (NAME[:WINDOW], learned:MODEL.pt, py:MODULE:FUNCTION,
    py:FILE.py:FUNCTION or cmd:TEMPLATE) on every axis of the suite, against the references,
    into --out.

    Resumable: rerun the same command and only missing or damaged work is redone.
    """
    from synth.cli.options import fail

    if compare:
        if matcher is not None:
            fail(ValueError(f"--compare makes the report of two finished runs; leave out "
                            f"MATCHER ({matcher!r})"))
        return _compare(ctx, compare, out, fail_on)
    if matcher is None:
        fail(ValueError("missing MATCHER (e.g. ct:9 or py:mine.py:match), or give --compare "
                        "OLD NEW"))
    if baseline is None and any(what == "regression" for what, _ in fail_on):
        fail(ValueError("--fail-on regression compares with a baseline: give --baseline DIR "
                        "(a finished validate folder)"))
    if workers > 1:  # the worker server imports while this process does
        from synth.dataset.engine.tasks import start_worker_server

        start_worker_server(["synth.validate.run", "synth.validate.pairs", "synth.pair"])
    from synth.validate.axes import AXES
    from synth.validate.run import run_validate

    chosen = None if axes is None else split_against(axes)
    unknown = [a for a in chosen or () if a not in AXES]
    if chosen is not None and (unknown or not chosen):
        what = f"unknown axis {unknown[0]!r}" if unknown else "no axis given"
        fail(ValueError(f"--axes: {what}; axes: {', '.join(AXES)}"))

    res = run_validate(matcher, out=out, suite=suite, against=split_against(against),
                       workers=workers, timeout=timeout, backend=backend, progress=True,
                       axes=chosen, battery=not skip_battery, real=real, baseline=baseline,
                       log=lambda line: click.echo(line, err=True))
    copied = f" ({res.pairs_copied} from the baseline)" if res.pairs_copied else ""
    click.echo(f"pairs: {res.pairs_rendered} rendered, {res.pairs_reused} reused{copied}; "
               f"estimates: {res.estimates_computed} computed, {res.estimates_reused} reused; "
               f"{res.seconds['total']:.1f} s")
    click.echo(f"results: {res.results}, differences: {out / 'differences.csv'}")
    if baseline is not None:
        inherited = " (the baseline's)" if not real and res.real else ""
        click.echo(f"real scenes compared with the baseline{inherited}: "
                   f"{', '.join(res.real) or 'none'}")
    status = 0
    if res.battery_ran:
        click.echo(f"properties: {out / 'properties.json'}, report: {out / 'report.html'}")
        if res.failed_properties:
            click.echo(f"required properties failed: {', '.join(res.failed_properties)}")
            status = max(status, int(any(what == "properties" for what, _ in fail_on)))
    for what, points in fail_on:
        found = res.regressions(points) if what == "regression" else []
        if found:
            for line in _regression_lines(found, res.baseline, baseline, points):
                click.echo(line)
            status = 1
    if status:
        raise SystemExit(status)
