"""``stereoforge paper``, ``study`` and ``golden``: the jobs built on the library."""

from __future__ import annotations

from pathlib import Path

import click

from synth.cli.options import LazyChoice, backend_option, fail, note, out_dir_option, workers_option

__all__ = ["golden", "paper", "study"]


@click.command()
@click.option("--data", "data", default="../shared/data/middlebury", show_default=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="Middlebury folder holding third/ and half/ scene folders.")
@click.option("--size", default="third", show_default=True, type=LazyChoice("synth.jobs.paper.tables:SIZES"))
@out_dir_option()
def paper(data, size, out) -> None:
    """Reproduce the seed paper's Tables 1-3 and figures on the real Middlebury scenes."""
    from synth.jobs.paper.tables import run_paper
    from synth._util.kernel_cache import MATCHER_KERNELS, compile_notice

    if not (data / size).is_dir():
        fail(FileNotFoundError(
            f"no {size}/ folder under {data}; pass --data pointing at the Middlebury scenes"))
    with compile_notice(MATCHER_KERNELS, note):
        report = run_paper(data, size=size, out=out, progress=True)
    click.echo(f"report: {report}")


@click.command()
@click.argument("config")
@out_dir_option()
@workers_option
@backend_option
@click.option("--matcher", "matchers", multiple=True, metavar="MATCHER",
              help="Also run this MATCHER string (NAME[:WINDOW], learned:MODEL.pt, py:..., "
                   "cmd:...) on every cell; repeatable.")
@click.option("--keep-pairs", is_flag=True,
              help="Keep every cell's pair in --out/pairs/ for `stereoforge eval-dataset`.")
def study(config, out, workers, backend, matchers, keep_pairs) -> None:
    """Texture frequency x window x method study from CONFIG (a .toml file or a shipped name).

    Resumable: rerun the same command and only the missing cells are computed.
    """
    if workers > 1:  # the worker server imports while this process does
        from synth.dataset.engine.tasks import start_worker_server

        start_worker_server(["synth.jobs.study.run"])
    from synth.jobs.study.run import run_study
    from synth._util.kernel_cache import MATCHER_KERNELS, compile_notice

    with compile_notice(MATCHER_KERNELS, note):  # the workers compile too: this times the parent
        path = run_study(config, out=out, workers=workers, progress=True, backend=backend,
                         matchers=matchers, keep_pairs=keep_pairs)
    click.echo(f"results: {path / 'results.csv'}, summary: {path / 'summary.md'}")


@click.group()
def golden() -> None:
    """Golden references: exact matcher outputs and tolerant render checks (golden/)."""


@golden.command("check")
@click.option("--root", default="golden", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--render/--no-render", default=True, show_default=True,
              help="Also re-render the golden scenes (needs GL) and compare within tolerances.")
@backend_option
def golden_check_cmd(root, render, backend) -> None:
    """Compare fresh matcher outputs (exactly) and renders (within tolerances) with golden/."""
    from synth.jobs.golden import golden_check

    if not (Path(root) / "manifest.json").is_file():  # missing, empty, or another kind of folder
        what = ("does not exist" if not Path(root).exists() else "is empty" if not
                any(Path(root).iterdir()) else "holds no manifest.json (not a golden folder)")
        raise click.BadParameter(f"{root} {what}; give the golden folder (the project's is "
                                 "golden/), or make one with `stereoforge golden update --root "
                                 f"{root}`", param_hint="--root")
    report = golden_check(root, backend=backend, render=render)
    click.echo(report.summary())
    if not report.ok:
        raise SystemExit(1)


@golden.command("update")
@click.option("--root", default="golden", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@backend_option
def golden_update_cmd(root, backend) -> None:
    """Regenerate golden/ and print what changed."""
    from synth.jobs.golden import format_changes, golden_update

    click.echo(format_changes(golden_update(root, backend=backend)))
