"""``stereoforge dataset``: many labelled pairs from one configuration."""

from __future__ import annotations

import click

from synth.cli.options import (backend_option, engine_option, format_option, note, out_dir_option,
                               workers_option)

__all__ = ["dataset"]


@click.command()
@click.argument("config", required=False)
@out_dir_option(required=False)
@click.option("--count", default=None, type=click.IntRange(min=1),
              help="Number of pairs [default: the config's count].")
@workers_option
@engine_option
@click.option("--address", default=None, help="Ray cluster address (engine ray); default: local.")
@format_option
@backend_option
@click.option("--verify", "verify_dir", default=None, metavar="DIR",
              type=click.Path(exists=True, file_okay=False),
              help="Check the dataset in DIR instead (sizes and SHA-256 of every file against "
                   "the samples' records; holes up to --count; extra files; the manifest): one "
                   "line per problem, exit 1 if any.")
def dataset(config, out, count, workers, engine, address, fmt, backend, verify_dir) -> None:
    """Generate a labelled dataset from CONFIG (a .toml file or a shipped example name), or check
    one with --verify DIR.

    Deterministic (same config, same bytes, whatever the worker count) and resumable: rerun the
    same command after an interruption and it finishes the missing samples.
    """
    if verify_dir is not None:
        if config is not None:
            raise click.UsageError("--verify DIR checks an existing dataset: drop CONFIG")
        from synth.dataset.integrity import verify_dataset

        problems = verify_dataset(verify_dir, count=count)
        for line in problems:
            click.echo(line)
        click.echo(f"{verify_dir}: {len(problems)} problem(s)" if problems else
                   f"{verify_dir}: complete, every file matches its record")
        raise SystemExit(1 if problems else 0)
    if config is None or out is None:
        raise click.UsageError("missing CONFIG (a .toml file or a shipped example name) and "
                               "--out DIR, or --verify DIR" if config is None else
                               "missing option '--out' (the dataset directory)")
    from synth.kernel_cache import DATASET_KERNELS, compile_notice

    with compile_notice(DATASET_KERNELS, note) as cold:
        if cold:  # compile here once, before any worker: the workers then load them from the cache
            from synth.dataset.warm import warm_sample_kernels

            warm_sample_kernels()
    if engine == "local" and workers > 1:  # the worker server imports while this process does
        from synth.dataset.engine import start_worker_server

        start_worker_server(["synth.dataset.run"])  # the task's module (the server adds its own)
    from synth.dataset import run_dataset

    # a failed sample (SampleError, exit 1) names its index and how to reproduce it alone
    run = run_dataset(config, out=out, count=count, workers=workers, engine=engine,
                      address=address, fmt=fmt, progress=True, backend=backend)
    click.echo(f"{run.count} samples in {run.out}: {run.rendered} rendered, {run.skipped} already "
               f"there, {run.seconds:.1f} s")
