"""The cameras of a stereo pair: the ideal rig, how real cameras deviate from it, their views.

- :mod:`synth.camera.rig` — :class:`StereoRig`: pinhole intrinsics, baseline, depth <-> disparity.
- :mod:`synth.camera.lens` — the real cameras (:class:`RigErrors`): OpenCV lens distortion, the
  right camera's rotation, offset and focal ratio, defocus.
- :mod:`synth.camera.imperfect` — views through the real cameras, their exact flow by ray
  casting, defocus blur (imported on its own: it needs trimesh and embreex).

The rig and camera-error classes are importable from here (``synth.camera.RigErrors``, where they
lived when ``synth.camera`` was one module, as error messages and docs name them); :mod:`synth`
exports them too.
"""

from synth.camera.lens import Defocus, Distortion, RigErrors
from synth.camera.rig import StereoRig

__all__ = ["Defocus", "Distortion", "RigErrors", "StereoRig"]
