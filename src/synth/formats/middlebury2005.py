"""Middlebury 2005/2006 scene folders (read only): named by ``middlebury:DIR[:DIVISOR]``.

::

    <size>/<Scene>/view1.png view5.png   left and right images
    <size>/<Scene>/disp1.png [disp5.png] 8-bit codes, disparity = code / DIVISOR, 0 = none

DIVISOR is 3 for the third-size release, 2 for half, 1 for full. Not given, it comes from the
nearest folder whose whole name says the size (``third``, ``HalfSize``, ...), checked against the
image size (:func:`matcher.io.find_middlebury_2005_divisor`,
:func:`matcher.io.check_middlebury_2005_divisor`); a folder more than two levels above the scene
is named in the scene's note. The ``middlebury`` layout's SPEC finds these folders beside the
2014 ones (:meth:`synth.formats.middlebury.MiddleburyLayout.open_spec`).
"""

from __future__ import annotations

from pathlib import Path

from matcher.io import (StereoSample, check_middlebury_2005_divisor, find_middlebury_2005_divisor,
                        load_middlebury_2005, read_image)
from synth.formats.base import Capacity, Layout, SceneRef, spec_error

__all__ = ["Middlebury2005Layout", "LAYOUT"]


class Middlebury2005Layout(Layout):
    """The 2005/2006 scene folders (``view1.png``, ``view5.png``, ``disp1.png``)."""

    name = "middlebury2005"
    title = "Middlebury 2005/2006"
    capacity = Capacity(right_disparity=True)
    writable = False

    def recognises(self, root: Path) -> bool:
        """One scene folder of the layout (``view1.png``)."""
        return (Path(root) / "view1.png").is_file()

    def discover(self, root: Path) -> list[str]:
        root = Path(root)
        if (root / "disp1.png").is_file():
            return ["."]
        return sorted(p.parent.name for p in root.glob("*/disp1.png"))

    def scene_ref(self, spec: str, folder: Path, *, scene: str,
                  divisor: float | None) -> SceneRef:
        """The scene in ``folder`` with its divisor: ``divisor`` as given, else inferred from
        the folder names and checked against the image size (see the module docstring).

        Raises
        ------
        ParameterError
            No ground truth, no folder that says the size, or one the image size contradicts.
        """
        if not (folder / "disp1.png").is_file():
            raise spec_error(spec, f"{folder} has no ground truth: no disp1.png; add it or give "
                                   "another scene")
        note = None
        if divisor is None:
            try:
                source = find_middlebury_2005_divisor(folder)
            except ValueError:
                raise spec_error(spec, f"cannot tell the disparity divisor of {folder} (no "
                                       "folder named third, half or full, or ThirdSize, "
                                       "HalfSize or FullSize); give it: middlebury:DIR:3 (third "
                                       "size), :2 (half) or :1 (full)") from None
            try:
                check_middlebury_2005_divisor(source, read_image(folder / "view1.png").shape,
                                              scene_dir=folder,
                                              fix="give it: middlebury:DIR:{divisor:g}")
            except ValueError as exc:
                raise spec_error(spec, str(exc).removeprefix("divisor: ")) from None
            divisor = source.divisor
            if source.far:
                note = (f"{scene}: divisor {divisor:g} from the folder {source.folder} "
                        f"({source.levels} levels above the scene)")
        return self.ref(folder, ".", scene=scene, divisor=divisor, note=note)

    def read_key(self, root: Path, key: str) -> StereoSample:
        """The scene folder ``root/key``, its divisor inferred from the folder names."""
        return load_middlebury_2005(Path(root) / key)

    def read_ref(self, ref: SceneRef) -> StereoSample:
        return load_middlebury_2005(Path(ref.root) / ref.key, divisor=ref.divisor)


LAYOUT = Middlebury2005Layout()
