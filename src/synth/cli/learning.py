"""``stereoforge train``: the reference learned matcher on stereoforge datasets and real scenes."""

from __future__ import annotations

import sys

import click

from synth.cli.options import note

__all__ = ["train_cmd"]


@click.command("train")
@click.argument("datasets", nargs=-1, required=True, metavar="DATASET [DATASET ...]")
@click.option("--out", "out", required=True, metavar="MODEL.pt",
              help="Model file to write; MODEL.csv (losses) and MODEL.pt.ckpt go beside it.")
@click.option("--minutes", default=None, type=float,
              help="Wall-time budget, data loading included (default 10 unless --steps).")
@click.option("--steps", default=None, type=click.IntRange(min=1),
              help="Step budget instead of --minutes (reproducible: --resume gives the same weights).")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(min=0))
@click.option("--device", default="auto", show_default=True,
              help="auto (CUDA when torch sees a GPU), cpu or cuda[:N].")
@click.option("--resume", is_flag=True, help="Continue from MODEL.pt.ckpt (same options).")
@click.option("--overwrite", is_flag=True, help="Start afresh over an existing model or checkpoint.")
@click.option("--workers", default=2, show_default=True, type=click.IntRange(min=0),
              help="DataLoader worker processes (0: load in this process).")
@click.option("--threads", default=None, type=click.IntRange(min=1),
              help="torch threads of the network (default: torch's choice, one per core).")
@click.option("--checkpoint-minutes", default=2.0, show_default=True, type=click.FloatRange(min=0.0),
              help="Wall time between checkpoints.")
@click.option("--arch", "arch", default="mccnn-fast", show_default=True, metavar="NAME",
              help="The network's architecture (matcher.learned.registry; docs/extending.md).")
@click.option("--arch-option", "arch_options", multiple=True, metavar="NAME=VALUE",
              help="An option of the architecture (repeatable), e.g. channels=64.")
@click.option("--channels", default=None, type=click.IntRange(min=1),
              help="Feature maps per layer (mccnn-fast's option channels; default 32).")
@click.option("--layers", default=None, type=click.IntRange(min=1),
              help="3x3 convolutions, patch side 2*layers+1 (mccnn-fast's option layers; "
                   "default 4).")
@click.option("--crops", default=None, type=click.IntRange(min=1),
              help="Crops per step, each from another pair (the batch); default 16 on the CPU, "
                   "256 on a GPU (there a step's crops go through the network in one pass).")
@click.option("--crop", default=32, show_default=True, type=click.IntRange(min=4),
              help="Side of a crop's block of left pixels (its patches).")
def train_cmd(datasets, out, minutes, steps, seed, device, resume, overwrite, workers, threads,
              checkpoint_minutes, arch, arch_options, channels, layers, crops, crop) -> None:
    """Train the reference learned matcher (MC-CNN-fast style) on DATASET(s).

    DATASET: a stereoforge dataset folder, or real scenes with ground truth:
    middlebury:DIR[:DIVISOR], kitti:DIR, eth3d:DIR, drivingstereo:DIR, skimage:motorcycle,
    sceneflow:DIR, crestereo:DIR, fsd:DIR (a plain folder of one of those is recognised too).
    Use the model anywhere a MATCHER is taken: learned:MODEL.pt (learned:MODEL.pt?device=cpu|
    cuda|cuda:N|auto names where it runs).
    """
    from synth.jobs.train import TrainConfig, TrainInterrupted, default_crops, train

    if minutes is None and steps is None:
        minutes = 10.0
    if crops is None:
        crops = default_crops(device)
    options = _arch_options(arch_options)
    for name, value in (("channels", channels), ("layers", layers)):
        if value is not None:
            options[name] = value
    cfg = TrainConfig(sources=tuple(datasets), out=out, minutes=minutes, steps=steps, seed=seed,
                      arch=arch, arch_options=options, crops=crops, crop=crop)
    try:
        result = train(cfg, device=device, resume=resume, overwrite=overwrite, workers=workers,
                       threads=threads, checkpoint_minutes=checkpoint_minutes, log=note)
    except TrainInterrupted as exc:
        note(str(exc))
        sys.exit(130)
    val = "" if result.val_loss is None else f", validation loss {result.val_loss:.4f}"
    click.echo(f"trained {result.steps} steps ({result.patches:,} patches) in "
               f"{result.seconds:.1f} s: train loss {result.train_loss:.4f}{val}; default "
               f"aggregation {result.aggregate}x{result.aggregate}; wrote {result.model} and "
               f"{result.csv}")


def _arch_options(pairs: tuple[str, ...]) -> dict[str, int]:
    """``--arch-option NAME=VALUE`` pairs as a dict of integers (checked by the architecture)."""
    out: dict[str, int] = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        try:
            if not sep or not name.strip():
                raise ValueError
            out[name.strip()] = int(value)
        except ValueError:
            raise click.BadParameter(f"expected NAME=INTEGER (e.g. channels=64), got {pair!r}",
                                     param_hint="--arch-option") from None
    return out
