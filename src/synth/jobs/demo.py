"""The built-in demo: every preset rendered into its own folder, and a contact sheet."""

from __future__ import annotations

from pathlib import Path


from scenes import list_presets
from synth.write.export import resolve_scene, staged_output_dir, write_pair
from synth._util.progress import progress as progress_bar
from synth.pair import render_pair
from synth.write.preview import contact_sheet
from synth.render.renderer import Renderer
from synth.camera.rig import StereoRig

__all__ = ["run_demo"]


def run_demo(
    out: str | Path,
    *,
    width: int = 320,
    height: int = 240,
    seed: int = 0,
    backend: str = "auto",
    overwrite: bool = False,
    progress: bool = False,
) -> Path:
    """Render every preset into ``out/<preset>/`` (Middlebury layout) and draw the contact sheet.

    Parameters
    ----------
    out : str or Path
        Output directory; must be empty unless ``overwrite``. Written as a whole
        (:func:`synth.write.export.staged_output_dir`): a failed demo leaves it as it was.
    width, height : int
        Image size of every pair.
    seed : int
        Seed of every preset.
    backend : {"auto", "egl", "osmesa"}
        GL backend.
    overwrite : bool
        Allow writing into a non-empty ``out``.
    progress : bool
        Show a progress bar.

    Returns
    -------
    Path
        ``out/contact_sheet.png``.
    """
    rig = StereoRig.default(width, height)
    names = [name for name, _ in list_presets()]
    rows = []
    # written into a staged folder that becomes ``out`` when complete: never half a demo
    with staged_output_dir(out, overwrite=overwrite) as stage:
        with Renderer(width, height, backend=backend) as renderer:
            for name in progress_bar(names, desc="demo", unit="scene", enabled=progress):
                spec, seed_used = resolve_scene(name, seed=seed)
                pair = render_pair(spec, rig, renderer=renderer)
                scene_dir = stage / name
                scene_dir.mkdir()
                write_pair(pair, scene_dir, scene=spec, seed=seed_used)
                rows.append((name, pair))
        contact_sheet(rows, stage / "contact_sheet.png")
    return Path(out) / "contact_sheet.png"
