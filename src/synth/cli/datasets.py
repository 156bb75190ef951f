"""``stereoforge dataset``: many labelled pairs from one configuration."""

from __future__ import annotations

import click

from synth.cli.options import backend_option, engine_option, format_option, out_dir_option, workers_option

__all__ = ["dataset"]


@click.command()
@click.argument("config")
@out_dir_option()
@click.option("--count", default=None, type=click.IntRange(min=1),
              help="Number of pairs [default: the config's count].")
@workers_option
@engine_option
@click.option("--address", default=None, help="Ray cluster address (engine ray); default: local.")
@format_option
@backend_option
def dataset(config, out, count, workers, engine, address, fmt, backend) -> None:
    """Generate a labelled dataset from CONFIG (a .toml file or a shipped example name).

    Deterministic (same config, same bytes, whatever the worker count) and resumable: rerun the
    same command after an interruption and it finishes the missing samples.
    """
    if engine == "local" and workers > 1:  # the worker server imports while this process does
        from synth.dataset.engine import start_worker_server

        start_worker_server(["synth.dataset.run"])  # the task's module (the server adds its own)
    from synth.dataset import run_dataset

    # a failed sample (SampleError, exit 1) names its index and how to reproduce it alone
    run = run_dataset(config, out=out, count=count, workers=workers, engine=engine,
                      address=address, fmt=fmt, progress=True, backend=backend)
    click.echo(f"{run.count} samples in {run.out}: {run.rendered} rendered, {run.skipped} already "
               f"there, {run.seconds:.1f} s")
