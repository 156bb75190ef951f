"""Contact sheets of the procedural object families and of dataset configurations.

:func:`family_sheet` renders each family of :data:`scenes.FAMILY_KINDS` (several seeds) and a
few deformed objects, one tile each: the left image beside its ground-truth disparity.
:func:`config_sheet` tiles the first samples of dataset configurations (left image, disparity)
as the dataset writes them, photometric models applied. ``docs/img/families.jpg`` and
``docs/img/configs.jpg`` are drawn by these (``python -m synth.jobs.sheets docs/img``).
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import scenes
from synth.camera.rig import StereoRig
from synth.pair import render_pair
from synth.render.renderer import Renderer
from synth.write.preview import colorize_disparity

__all__ = ["family_sheet", "config_sheet", "DEFORMED_EXAMPLES"]

#: ``(kind, (twist, bend, taper))`` of the deformed objects on the family sheet.
DEFORMED_EXAMPLES: tuple[tuple[str, tuple[float, float, float]], ...] = (
    ("box", (1.2, 0.0, 0.0)), ("box", (0.0, 0.8, 0.0)), ("cylinder", (0.0, 0.0, 0.6)),
    ("revolution", (0.6, 0.6, -0.4)), ("superquadric", (0.0, -0.8, 0.4)))

#: Size of each family's object on its tile (metres), at 2.5 m.
_SIZES = {"superquadric": (0.9, 0.7, 0.8), "rock": (0.5,), "torus": (0.42, 0.13),
          "knot": (0.5, 0.055), "revolution": (0.35, 0.95), "extrusion": (0.5, 0.4),
          "polyhedron": (0.5,), "tree": (0.9, 1.1), "bush": (1.0, 0.7), "wire": (1.1, 0.03),
          "furniture": (0.8, 0.9, 0.6), "box": (0.5, 0.8, 0.5), "cylinder": (0.3, 0.9)}


def _object_scene(kind: str, seed: int, deform: tuple[float, float, float]) -> scenes.SceneSpec:
    rng = np.random.default_rng(seed)
    texture = scenes.TextureSpec(kind=str(rng.choice(["noise", "checker", "stripes"])),
                                 frequency=float(rng.uniform(12.0, 30.0)), contrast=0.8,
                                 color=tuple(float(c) for c in rng.uniform(0.55, 1.0, 3)),
                                 seed=seed, angle=float(rng.uniform(0.0, 180.0)))
    obj = scenes.ObjectSpec(kind, scenes.Pose(translation=(0.05, 0.0, 2.5),
                                              rotation_deg=(15.0, 30.0 + 40.0 * seed, 5.0)),
                            _SIZES[kind], texture, name=kind, segments=48, seed=seed,
                            deform=deform)
    wall = scenes.get_preset("fronto_plane", seed=seed).objects[0]
    wall = dataclasses.replace(wall, pose=scenes.Pose(translation=(0.05, 0.0, 5.0)),
                               size=(8.0, 6.0),
                               texture=dataclasses.replace(wall.texture, contrast=0.35))
    return scenes.SceneSpec(kind, (obj, wall))


def _tile(left: np.ndarray, disparity: np.ndarray, label: str) -> np.ndarray:
    left = np.asarray(left)
    if left.ndim == 2:
        left = np.repeat(left[..., None], 3, axis=2)
    tile = np.concatenate([left[..., :3], colorize_disparity(disparity)], axis=1)
    image = Image.fromarray(np.ascontiguousarray(tile))
    ImageDraw.Draw(image).text((4, 3), label, fill=(255, 255, 0))
    return np.asarray(image)


def _grid(tiles: Sequence[np.ndarray], columns: int) -> Image.Image:
    h, w = tiles[0].shape[:2]
    rows = -(-len(tiles) // columns)
    sheet = np.zeros((rows * (h + 4), columns * (w + 4), 3), np.uint8)
    for i, tile in enumerate(tiles):
        r, c = divmod(i, columns)
        sheet[r * (h + 4):r * (h + 4) + h, c * (w + 4):c * (w + 4) + w] = tile
    return Image.fromarray(sheet)


def _save(image: Image.Image, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    image.save(tmp, format="JPEG" if path.suffix.lower() in (".jpg", ".jpeg") else "PNG",
               quality=88)
    tmp.replace(path)  # never half a picture
    return path


def family_sheet(path: str | Path, *, width: int = 240, height: int = 180,
                 seeds: Sequence[int] = (0, 1), columns: int = 4,
                 backend: str = "auto") -> Path:
    """Draw every family (one tile per seed) and :data:`DEFORMED_EXAMPLES` into ``path``.

    Returns
    -------
    Path
        ``path`` (JPEG or PNG by its suffix).
    """
    rig = StereoRig.default(width, height)
    cases = [(kind, seed, (0.0, 0.0, 0.0)) for kind in scenes.FAMILY_KINDS for seed in seeds]
    cases += [(kind, 0, deform) for kind, deform in DEFORMED_EXAMPLES]
    tiles = []
    with Renderer(width, height, backend=backend) as renderer:
        for kind, seed, deform in cases:
            pair = render_pair(_object_scene(kind, seed, deform), rig, renderer=renderer)
            name = f"{kind} seed {seed}" if not any(deform) else (
                f"{kind} twist/bend/taper {'/'.join(f'{v:g}' for v in deform)}")
            tiles.append(_tile(pair.left, pair.disp_left, name))
    return _save(_grid(tiles, columns), Path(path))


def config_sheet(path: str | Path, configs: Sequence[str], *, count: int = 3,
                 width: int = 384, height: int = 216, backend: str = "auto") -> Path:
    """Draw samples ``0..count-1`` of each configuration (a row each) into ``path``: the left
    image as written (photometric models applied) beside its disparity, at ``width`` x
    ``height`` (the rig scaled, as ``dataset --size`` does)."""
    import tempfile

    from matcher.io import read_pfm
    from synth.dataset.config.parse import load_config, resized
    from synth.dataset.sample import produce_sample

    tiles = []
    with Renderer(width, height, backend=backend) as renderer, \
            tempfile.TemporaryDirectory() as tmp:
        for name in configs:
            config = resized(load_config(name), width, height)
            for index in range(count):
                dest = Path(tmp) / f"{config.name}-{index}"
                produce_sample(config, index, renderer, dest, "middlebury")
                with Image.open(dest / "im0.png") as image:
                    left = np.asarray(image.convert("RGB"))
                tiles.append(_tile(left, read_pfm(dest / "disp0GT.pfm"),
                                   f"{config.name} {index}"))
    return _save(_grid(tiles, count), Path(path))


def main(argv: Sequence[str] | None = None) -> None:
    """``python -m synth.jobs.sheets DIR``: ``DIR/families.jpg`` and ``DIR/configs.jpg``."""
    args = list(sys.argv[1:] if argv is None else argv)
    out = Path(args[0] if args else "docs/img")
    print(family_sheet(out / "families.jpg"))
    print(config_sheet(out / "configs.jpg", ["flying", "middlebury-like", "floating", "dense",
                                             "outdoor"]))


if __name__ == "__main__":  # pragma: no cover
    main()
