"""``stereoforge dataset``: many labelled pairs from one configuration."""

from __future__ import annotations

from pathlib import Path

import click

from synth.cli.options import LazyChoice, backend_option, engine_option, fail, out_dir_option, workers_option

__all__ = ["dataset"]


@click.command()
@click.argument("config", required=False)
@out_dir_option(required=False)
@click.option("--count", default=None, type=click.IntRange(min=1),
              help="Number of pairs [default: the config's count].")
@workers_option
@engine_option
@click.option("--address", default=None, help="Ray cluster address (engine ray); default: local.")
@click.option("--format", "fmt", default="middlebury", show_default=True,
              type=LazyChoice("synth.formats:DATASET_FORMATS"),
              help="Sample folders (middlebury, kitti) or tar shards (webdataset).")
@click.option("--shard-size", "shard_size", default=None, metavar="BYTES",
              help="Bytes per tar shard of --format webdataset, e.g. 1GB, 500MB [default: 1GB].")
@backend_option
@click.option("--upgrade", "upgrade", default=None, metavar="DIR",
              type=click.Path(file_okay=False, path_type=Path),
              help="Convert DIR, a dataset of the previous layout (sample folders at the root), "
                   "in place to this one (MiddEval3/trainingF/, training/samples/); no CONFIG.")
def dataset(config, out, count, workers, engine, address, fmt, shard_size, backend,
            upgrade) -> None:
    """Generate a labelled dataset from CONFIG (a .toml file or a shipped example name).

    Deterministic (same config, same bytes, whatever the worker count) and resumable: rerun the
    same command after an interruption and it finishes the missing samples.
    """
    if upgrade is not None:
        if config is not None or out is not None:
            fail(ValueError("--upgrade DIR takes no CONFIG and no --out (it converts DIR in place)"))
        from synth.dataset.layout import upgrade_dataset

        try:
            moved = upgrade_dataset(upgrade)
        except ValueError as exc:
            fail(exc)
        click.echo(f"{upgrade}: {moved} sample folders moved; layout is current")
        return
    if config is None or out is None:
        fail(ValueError("give CONFIG and --out DIRECTORY (or --upgrade DIR)"))
    if shard_size is not None:
        from synth.dataset.shards import check_shard_option, parse_size

        try:
            shard_size = check_shard_option(fmt, parse_size(shard_size))
        except ValueError as exc:
            fail(exc)
    if engine == "local" and workers > 1:  # the worker server imports while this process does
        from synth.dataset.engine import start_worker_server

        start_worker_server(["synth.dataset.run"])  # the task's module (the server adds its own)
    from synth.dataset import SampleError, run_dataset

    try:
        run = run_dataset(config, out=out, count=count, workers=workers, engine=engine,
                          address=address, fmt=fmt, progress=True, backend=backend,
                          shard_size=shard_size)
    except (ValueError, FileNotFoundError) as exc:
        fail(exc)
    except SampleError as exc:  # a sample failed: name it and how to reproduce it alone
        raise click.ClickException(str(exc)) from exc
    click.echo(f"{run.count} samples in {run.out}: {run.rendered} rendered, {run.skipped} already "
               f"there, {run.seconds:.1f} s")
