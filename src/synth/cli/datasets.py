"""``stereoforge dataset``: many labelled pairs from one configuration."""

from __future__ import annotations

from pathlib import Path

import click

from synth.cli.options import (LazyChoice, address_option, backend_option, engine_option, note,
                               out_dir_option, workers_option)
from synth.formats import DEFAULT_FORMAT

__all__ = ["dataset"]


@click.command()
@click.argument("config", required=False)
@out_dir_option(required=False, url=True,
                help="Dataset directory, or an fsspec URL (s3://bucket/prefix with s3fs, "
                     "gs://... with gcsfs; needs pip install 'stereoforge[storage]').")
@click.option("--count", default=None, type=click.IntRange(min=1),
              help="Number of pairs [default: the config's count].")
@click.option("--indices", default=None, metavar="START:STOP",
              help="Render only samples START .. STOP-1 of the --count (Python slice; 5000: runs "
                   "to --count): one part, for several drivers writing one --out at once on "
                   "disjoint ranges. Parts write no manifest: when all have ended, rerun without "
                   "--indices to write it (it renders only what is missing).")
@workers_option
@engine_option
@address_option
@click.option("--format", "fmt", default=DEFAULT_FORMAT, show_default=True,
              type=LazyChoice("synth.formats:DATASET_FORMATS"),
              help="Sample folders (middlebury: MiddEval3, middlebury2014: the 2014 scene "
                   "archives, kitti; the training layouts sceneflow: FlyingThings3D's tree, "
                   "crestereo, fsd: FoundationStereo's; docs/formats.md) or tar shards "
                   "(webdataset).")
@click.option("--size", "size_text", default=None, metavar="WxH",
              help="Render at this size instead of the config's, fx scaled with the width "
                   "(e.g. 960x540, FlyingThings3D's); another config hash than the file's.")
@click.option("--shard-size", "shard_size", default=None, metavar="BYTES",
              help="Bytes per tar shard of --format webdataset, e.g. 1GB, 500MB [default: 1GB].")
@click.option("--disp-encoding", "disp_encoding", default=None,
              type=LazyChoice("synth.dataset.storage.shards:DISP_ENCODINGS"),
              help="How --format webdataset stores disparities and depth: pfm, or pfm.gz "
                   "(gzip, lossless) [default: pfm].")
@backend_option
@click.option("--verify", "verify_dir", default=None, metavar="DIR",
              help="Check the dataset in DIR (a folder or an fsspec URL) instead (sizes and "
                   "SHA-256 of every file against the samples' records; holes up to --count; extra files; the manifest): one "
                   "line per problem, exit 1 if any.")
@click.option("--compare", "compare", default=None, nargs=2, metavar="A B",
              help="Compare datasets (or any folders) A and B file by file instead: one line per "
                   "file that is not byte-identical, saying whether its content differs (pixels, "
                   "values: how many, how much, where) or only its encoding (e.g. another "
                   "deflate library); exit 1 if any content differs.")
@click.option("--bytes", "require_bytes", is_flag=True,
              help="With --compare: exit 1 also when only encodings differ.")
@click.option("--upgrade", "upgrade", default=None, metavar="DIR",
              type=click.Path(exists=True, file_okay=False, path_type=Path),
              help="Convert DIR, a dataset of the previous layout (sample folders at the root), "
                   "in place to this one (MiddEval3/trainingF/, training/samples/, records/); "
                   "no CONFIG.")
def dataset(config, out, count, indices, workers, engine, address, fmt, size_text, shard_size,
            disp_encoding, backend, verify_dir, compare, require_bytes, upgrade) -> None:
    """Generate a labelled dataset from CONFIG (a .toml file or a shipped example name), check
    one with --verify DIR, compare two with --compare A B, or convert one of the previous layout
    with --upgrade DIR.

    Deterministic (same config, same bytes, whatever the worker count) and resumable: rerun the
    same command after an interruption and it finishes the missing samples.
    """
    if indices is not None and (upgrade is not None or verify_dir is not None
                                or compare is not None):
        raise click.UsageError("--indices chooses the samples a run renders: drop it with "
                               "--verify, --compare and --upgrade (they check, compare or "
                               "convert whole datasets)")
    if require_bytes and compare is None:
        raise click.UsageError("--bytes applies to --compare A B only; drop it")
    if compare is not None:
        if config is not None or out is not None or verify_dir is not None or upgrade is not None:
            raise click.UsageError("--compare A B compares two existing datasets: drop CONFIG, "
                                   "--out, --verify and --upgrade")
        _compare(*compare, require_bytes=require_bytes)
        return
    if upgrade is not None:
        if config is not None or out is not None or verify_dir is not None:
            raise click.UsageError("--upgrade DIR converts DIR in place: drop CONFIG, --out and "
                                   "--verify")
        from synth.dataset.storage.layout import upgrade_dataset

        moved = upgrade_dataset(upgrade)
        click.echo(f"{upgrade}: {moved} sample folders moved; layout is current")
        return
    if verify_dir is not None:
        if config is not None:
            raise click.UsageError("--verify DIR checks an existing dataset: drop CONFIG")
        from synth.dataset.storage.integrity import verify_dataset

        problems = verify_dataset(verify_dir, count=count)
        for line in problems:
            click.echo(line)
        click.echo(f"{verify_dir}: {len(problems)} problem(s)" if problems else
                   f"{verify_dir}: complete, every file matches its record")
        raise SystemExit(1 if problems else 0)
    if config is None or out is None:
        raise click.UsageError("missing CONFIG (a .toml file or a shipped example name) and "
                               "--out DIR, or --verify DIR, or --upgrade DIR" if config is None else
                               "missing option '--out' (the dataset directory)")
    if size_text is not None:  # WxH, checked before any work
        from synth.dataset.config.parse import load_config, resized
        from synth.jobs.bench.render import parse_sizes

        try:
            sizes = parse_sizes(size_text)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--size") from None
        if len(sizes) != 1:
            raise click.BadParameter(f"expected one WxH, got {size_text!r}", param_hint="--size")
        config = resized(load_config(config), *sizes[0])
    if indices is not None:  # START:STOP -> a range, checked against the count, before any work
        from synth.dataset.config.parse import load_config
        from synth.dataset.parts import parse_indices

        config = load_config(config)
        indices = parse_indices(indices, config.count if count is None else count, fmt=fmt)
    if shard_size is not None:  # refused with a format without shards, before any work
        from synth.dataset.storage.shards import check_shard_option, parse_size

        shard_size = check_shard_option(fmt, parse_size(shard_size))
    if disp_encoding is not None:
        from synth.dataset.storage.shards import check_disp_encoding

        disp_encoding = check_disp_encoding(fmt, disp_encoding)
    from synth._util.kernel_cache import DATASET_KERNELS, compile_notice

    with compile_notice(DATASET_KERNELS, note) as cold:
        if cold:  # compile here once, before any worker: the workers then load them from the cache
            from synth.dataset.engine.warm import warm_sample_kernels

            warm_sample_kernels()
    if engine == "local" and workers > 1:  # the worker server imports while this process does
        from synth.dataset.engine.tasks import start_worker_server

        start_worker_server(["synth.dataset.run"])  # the task's module (the server adds its own)
    from synth.dataset import run_dataset

    # a failed sample (SampleError, exit 1) names its index and how to reproduce it alone
    run = run_dataset(config, out=out, count=count, workers=workers, engine=engine,
                      address=address, fmt=fmt, progress=True, backend=backend,
                      shard_size=shard_size, disp_encoding=disp_encoding, indices=indices)
    if run.indices != range(run.count):
        click.echo(f"samples {run.indices.start}:{run.indices.stop} of {run.count} in {run.out}: "
                   f"{_rendered(run)}, {run.skipped} already there, {run.seconds:.1f} s; "
                   "no manifest written: once every part has ended, rerun without --indices")
    else:
        click.echo(f"{run.count} samples in {run.out}: {_rendered(run)}, {run.skipped} already "
                   f"there, {run.seconds:.1f} s")
    for line in run.notes:
        note(line)
    for index, problems in run.damaged:
        more = f" (and {len(problems) - 2} more)" if len(problems) > 2 else ""
        click.echo(f"  {index:06d} rendered again: {'; '.join(problems[:2])}{more}")


def _rendered(run) -> str:
    """``N rendered``, and how many of them were found damaged (listed after the summary)."""
    if not run.damaged:
        return f"{run.rendered} rendered"
    return (f"{run.rendered} rendered ({len(run.damaged)} found damaged or incomplete and rendered "
            "again, below)")


def _compare(a: str, b: str, *, require_bytes: bool) -> None:
    from pathlib import Path

    from synth.dataset.compare import compare_datasets, same_content, summarize
    from synth.dataset.compare_layouts import compare_layouts, dataset_formats

    try:
        formats = dataset_formats(Path(a), Path(b)) if "://" not in a + b else None
        if formats and require_bytes:
            raise click.BadParameter(f"{a} is --format {formats[0]} and {b} --format "
                                     f"{formats[1]}: their files cannot be byte-identical; drop "
                                     "--bytes to compare their samples", param_hint="--bytes")
        if formats:  # two layouts: sample by sample, within each layout's quantum
            click.echo(f"{a} is --format {formats[0]}, {b} --format {formats[1]}: comparing "
                       "samples (pixels, ground truth within the quantum, calibration)")
            differences = compare_layouts(a, b)
        else:
            differences = compare_datasets(a, b)
    except FileNotFoundError as exc:
        raise click.BadParameter(str(exc), param_hint="--compare") from None
    for d in differences:
        click.echo(f"{d.kind:8} {d}")
    if formats and not differences:
        click.echo(f"{a} vs {b}: the same samples (pixels, ground truth within the quantum, "
                   "calibration)")
    else:
        click.echo(f"{a} vs {b}: {summarize(differences)}")
    if differences and (require_bytes or not same_content(differences)):
        raise SystemExit(1)
