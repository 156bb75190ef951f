"""``stereoforge presets``, ``render`` and ``demo``: scenes and single pairs."""

from __future__ import annotations

from pathlib import Path

import click

from synth.cli.options import (
    backend_option,
    fail,
    format_option,
    out_dir_option,
    overwrite_option,
    size_options,
)

__all__ = ["demo", "presets", "render"]


@click.command()
def presets() -> None:
    """List the built-in scenes with a one-line description each."""
    from scenes import list_presets

    rows = list_presets()
    width = max(len(name) for name, _ in rows)
    for name, description in rows:
        click.echo(f"{name:<{width}}  {description}")


@click.command()
@click.argument("scene", required=False)
@out_dir_option(help="Output directory (must be empty unless --overwrite).")
@size_options(width=640, height=480)
@click.option("--fx", default=None, type=float, help="Focal length in pixels [default: 600·width/640].")
@click.option("--baseline", default=0.1, show_default=True, type=float, help="Baseline in metres.")
@click.option("--seed", default=None, type=int, help="Seed of a preset [default: 0].")
@format_option
@backend_option
@overwrite_option
@click.option("--from-manifest", "from_manifest", nargs=2, default=None,
              type=(str, int), metavar="DIR INDEX",
              help="Re-render sample INDEX of the dataset in DIR (a folder or an fsspec URL, "
                   "e.g. s3://bucket/prefix) alone (same bytes), instead of SCENE.")
@click.option("--exposure-variant", "exposure", default=None, type=float, metavar="FACTOR",
              help="Write im1E.png: the right view with its linear radiance times FACTOR "
                   "(Middlebury layout).")
@click.option("--lighting-variant", "relight", default=None, type=float, metavar="DEGREES",
              help="Write im1L.png: the right view rendered again with every light direction "
                   "turned by DEGREES (Middlebury layout).")
@click.option("--ground-truth", "ground_truth", default=None, metavar="KINDS",
              help="Also write optional ground truth, comma-separated: depth, normals, instance, "
                   "semantic, occlusion_right (Middlebury format; see docs/datasets.md).")
def render(scene, out, width, height, fx, baseline, seed, fmt, backend, overwrite,
           from_manifest, exposure, relight, ground_truth) -> None:
    """Render SCENE (a preset name or a .toml/.json scene file) as a labelled stereo pair."""
    from synth import StereoRig, render_pair
    from synth.write.export import resolve_scene, save_pair

    if from_manifest is not None:
        from synth import render_from_manifest

        if scene is not None:
            fail(ValueError("give either SCENE or --from-manifest DIR INDEX, not both"))
        written = render_from_manifest(from_manifest[0], from_manifest[1], out=out,
                                       overwrite=overwrite, backend=backend)
        click.echo(f"wrote {len(written)} files to {out}")
        return
    if scene is None:
        fail(ValueError("missing SCENE (a preset name or a scene file), or --from-manifest DIR INDEX"))
    kinds = ()
    if ground_truth is not None:  # checked before any work
        from synth.write.extra_ground_truth import check_extra_kinds

        kinds = check_extra_kinds(ground_truth, where="--ground-truth")
        if kinds:
            from synth.formats import get_layout

            layout = get_layout(fmt)
            if not layout.capacity.extra_ground_truth:
                fail(ValueError(f"--ground-truth has no place in the {layout.title} layout; use "
                                "--format middlebury or drop --ground-truth"))
    spec, seed = resolve_scene(scene, seed=seed)
    rig = StereoRig.default(width, height, fx=fx, baseline=baseline)
    from synth.formats import get_layout

    get_layout(fmt).check_rig(rig, source="stereoforge render")  # before anything is rendered
    lighting = None
    if relight is not None:
        import dataclasses

        import numpy as np
        from scenes.materials import turn_lights

        light, lamps = turn_lights(spec, relight, np.random.default_rng(seed))
        lighting = dataclasses.replace(spec, light=light, lamps=lamps)
    extra = None
    if kinds:
        from synth.write.extra_ground_truth import render_ground_truth
        from synth.render import Renderer

        with Renderer(rig.width, rig.height, backend=backend) as renderer:
            pair = render_pair(spec, rig, renderer=renderer, exposure=exposure, lighting=lighting)
            extra = render_ground_truth(pair, spec, kinds, renderer=renderer)
    else:  # validates before anything is written
        pair = render_pair(spec, rig, backend=backend, exposure=exposure, lighting=lighting)
    written = save_pair(pair, out, scene=spec, seed=seed, fmt=fmt, overwrite=overwrite,
                        ground_truth=extra)
    click.echo(f"wrote {len(written)} files to {out}")


@click.command()
@out_dir_option(default="out/demo")
@size_options(width=320, height=240, minimum=16)
@click.option("--seed", default=0, show_default=True, type=int)
@backend_option
@overwrite_option
def demo(out, width, height, seed, backend, overwrite) -> None:
    """Render every preset into OUT/<preset>/ and draw OUT/contact_sheet.png."""
    from synth.jobs.demo import run_demo

    sheet = run_demo(out, width=width, height=height, seed=seed, backend=backend,
                     overwrite=overwrite, progress=True)
    click.echo(f"contact sheet: {sheet}")
