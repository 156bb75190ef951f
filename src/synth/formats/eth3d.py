"""``eth3d:DIR`` (read only): the ETH3D two-view benchmark's training scenes.

::

    DIR/two_view_training/<scene>/       im0.png im1.png calib.txt [cameras.txt images.txt]
    DIR/two_view_training_gt/<scene>/    disp0GT.pfm (float32, inf = none) mask0nocc.png

as the archives unpack (``DIR`` may also be ``two_view_training/`` itself, or a folder of scene
folders holding the images and the ground truth together). The files are Middlebury 2014's:
``mask0nocc.png`` is 255 visible in both views, 128 occluded, 0 no ground truth; ``calib.txt``'s
``ndisp`` is the image width, not a search range. The images are grey stored as RGB. The field
reports bad-1 on the non-occluded pixels (:data:`synth.formats.METRICS`).
"""

from __future__ import annotations

from pathlib import Path

from matcher.io import StereoSample, read_calib, read_disparity, read_image
from matcher.io.sample import check_sample_shapes
from synth.formats.base import Capacity, Layout, SceneRef
from synth.formats.reading import calib_from_middlebury

__all__ = ["ETH3DLayout", "LAYOUT"]

#: The archives' folders of images and of ground truth.
IMAGES, TRUTH = "two_view_training", "two_view_training_gt"


def _truth_folder(images: Path) -> Path:
    """Where the ground truth of the scene whose images are in ``images`` is."""
    if images.parent.name == IMAGES and (images.parent.parent / TRUTH / images.name).is_dir():
        return images.parent.parent / TRUTH / images.name
    return images


class ETH3DLayout(Layout):
    """ETH3D two-view scene folders, images and ground truth in sibling trees."""

    name = "eth3d"
    title = "ETH3D two-view"
    capacity = Capacity(right_disparity=False)
    writable = False
    spec_form = "eth3d:DIR"
    metric = "bad1_nonocc"

    def _image_folders(self, root: Path) -> list[Path]:
        for base in (root / IMAGES, root):
            if (base / "im0.png").is_file():
                return [base]
            found = sorted(p.parent for p in base.glob("*/im0.png"))
            if found:
                return found
        return []

    def recognises(self, root: Path) -> bool:
        return (Path(root) / IMAGES).is_dir() or Path(root).name == IMAGES

    def discover(self, root: Path) -> list[str]:
        """The scene folders with ``im0.png``, ``im1.png`` and a ``disp0GT.pfm``, as paths from
        ``root`` (``"."``: ``root`` is one scene)."""
        root = Path(root)
        return [p.relative_to(root).as_posix() or "." for p in self._image_folders(root)
                if (p / "im1.png").is_file() and (_truth_folder(p) / "disp0GT.pfm").is_file()]

    def open_spec(self, spec: str, rest: str) -> list[SceneRef]:
        return [self.ref(Path(r.root), r.key, scene=f"eth3d:{r.name}", name=r.name)
                for r in super().open_spec(spec, rest)]

    def read_key(self, root: Path, key: str) -> StereoSample:
        images = Path(root) / key
        truth = _truth_folder(images)
        left, right = read_image(images / "im0.png"), read_image(images / "im1.png")
        disp = read_disparity(truth / "disp0GT.pfm")
        mask = read_image(truth / "mask0nocc.png") if (truth / "mask0nocc.png").is_file() else None
        if mask is not None and mask.ndim != 2:
            raise ValueError(f"{truth / 'mask0nocc.png'}: expected a grey mask, got shape "
                             f"{mask.shape}")
        check_sample_shapes(images, left, right, disp, mask)
        calib = read_calib(images / "calib.txt") if (images / "calib.txt").is_file() else None
        return StereoSample(left, right, disp, None, images.resolve().name,
                            {"dataset": "eth3d", "layout": self.name, "scene_dir": str(images)},
                            mask, calib_from_middlebury(calib))


LAYOUT = ETH3DLayout()
