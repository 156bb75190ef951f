"""``--format middlebury2014``: scene folders as in the Middlebury 2014 archives.

::

    2014/000000/    im0.png im1.png im1E.png im1L.png disp0.pfm disp1.pfm mask0nocc.png calib.txt
                    [flow0.flo] scene.json sample.json [preview.png]

``2014/<scene>/`` is where RAFT-Stereo's ``Middlebury(root, split="2014")`` takes every entry for a
scene folder, so ``2014/`` holds nothing else. The files are MiddEval3's with the ground truth
named as in the archives (``disp0.pfm``, ``disp1.pfm``).
"""

from __future__ import annotations

from pathlib import Path

from synth.formats.middlebury import MiddleburyLayout

__all__ = ["Middlebury2014Layout", "LAYOUT"]


class Middlebury2014Layout(MiddleburyLayout):
    """The 2014 archives' scene folders (``layout="2014"`` of :func:`matcher.io.write_middlebury`)."""

    name = "middlebury2014"
    title = "Middlebury 2014"
    tools_root = "2014"
    sample_parent = "2014"
    io_layout = "2014"
    spec_form = None  # its scene folders are named by middlebury:DIR

    def recognises(self, root: Path) -> bool:
        """One scene folder of the 2014 / MiddEval3 layout (``im0.png``)."""
        return (Path(root) / "im0.png").is_file()

    def finish_files(self, names: list[str]) -> dict[str, bytes]:
        return {}


LAYOUT = Middlebury2014Layout()
