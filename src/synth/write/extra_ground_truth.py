"""Optional ground truth beyond disparity: depth, surface normals, instance and semantic masks,
the right view's occlusion mask; rendered (a GT pass), never estimated from the images.

Files (in a Middlebury scene folder; fields of a WebDataset shard, see docs/datasets.md; written
and read by :mod:`synth.formats.extras`):

=================  ===================  ===================================================
kind               file                 encoding
=================  ===================  ===================================================
``depth``          ``depth0.pfm``       float32 ``Z`` of the left view in metres (the exact
                                        float depth pass), ``inf`` where no surface
``normals``        ``normals0.pfm``     3-channel float32 unit normal in the left camera's
                                        axes (x right, y down, z forward), turned toward
                                        the camera; 0 0 0 where no surface
``instance``       ``instance0.png``    16-bit grey: 1 + the object's index in the scene
                                        (scene order), 0 background
``semantic``       ``semantic0.png``    8-bit grey: the object's kind, the index in
                                        :data:`SEMANTIC_CLASSES` (0 background; 255 a kind
                                        not in the table)
``occlusion_right``  ``mask1nocc.png``  the right view's mask, coded as ``mask0nocc.png``:
                                        255 visible in both views, 128 occluded in the left
                                        view, 0 no surface
=================  ===================  ===================================================

Normals and instance ids come from one extra pass (:meth:`synth.render.Renderer.render_labels`)
with the depth pass's visibility test, so every pixel's label belongs to the surface whose depth
is in ``depth0.pfm``. Normals are the mesh's vertex normals interpolated across each triangle
(exact on flat faces, tessellation-accurate on curved ones).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from stereoforge.errors import ParameterError
from synth.formats.extras import GROUND_TRUTH

__all__ = ["SEMANTIC_CLASSES", "OTHER_CLASS", "check_extra_kinds", "right_occlusion_mask",
           "semantic_lut", "render_ground_truth"]

#: Semantic class ids: the index of the object's kind (``scenes.ObjectSpec.kind``).
SEMANTIC_CLASSES = ("background", "plane", "box", "sphere", "cylinder", "moebius", "terrain")
#: Semantic id of an object whose kind is not in :data:`SEMANTIC_CLASSES`.
OTHER_CLASS = 255
_MAX_INSTANCES = 65535  # 16-bit PNG


def check_extra_kinds(kinds: Iterable[str] | None, *, where: str = "ground_truth"
                       ) -> tuple[str, ...]:
    """The requested kinds in canonical order; unknown or repeated kinds raise ParameterError."""
    if kinds is None:
        return ()
    if isinstance(kinds, str):
        kinds = [k for k in kinds.split(",") if k]
    kinds = list(kinds)
    bad = [k for k in kinds if k not in GROUND_TRUTH]
    if bad or len(set(kinds)) != len(kinds):
        raise ParameterError(f"{where}: expected distinct kinds among {', '.join(GROUND_TRUTH)}, "
                             f"got {kinds!r}")
    return tuple(k for k in GROUND_TRUTH if k in kinds)


def right_occlusion_mask(disp_left: np.ndarray, disp_right: np.ndarray) -> np.ndarray:
    """The right view's mask (255 visible, 128 occluded in the left view, 0 no surface).

    The left view's rule (:func:`synth.pair.occlusion_mask`) applied to the mirrored views: a
    right pixel ``x`` with disparity ``d`` is seen by the left view at ``x + d``.

    Examples
    --------
    >>> dl, dr = np.array([[2.0, 2.0, 1.0, 1.0]]), np.array([[2.0, 1.0, 1.0, np.inf]])
    >>> right_occlusion_mask(dl, dr).tolist()
    [[128, 255, 255, 0]]
    """
    from synth.pair import occlusion_mask

    return occlusion_mask(disp_right[:, ::-1], disp_left[:, ::-1])[:, ::-1].copy()


def semantic_lut(scene: Any) -> np.ndarray:
    """(n_objects + 1,) uint8: the semantic id of each instance id (0: background)."""
    if hasattr(scene, "objects"):
        kinds = [o.kind for o in scene.objects]
    else:
        kinds = [m.metadata.get("kind") for m in scene]
    ids = [SEMANTIC_CLASSES.index(k) if k in SEMANTIC_CLASSES else OTHER_CLASS for k in kinds]
    return np.array([0, *ids], dtype=np.uint8)


def render_ground_truth(pair: Any, scene: Any, kinds: Iterable[str], *,
                        renderer: Any) -> dict[str, np.ndarray]:
    """The arrays of the requested kinds for ``pair`` (rendered from ``scene`` by ``renderer``)."""
    kinds = check_extra_kinds(kinds)
    out: dict[str, np.ndarray] = {}
    if "depth" in kinds:
        out["depth"] = np.asarray(pair.depth_left, dtype=np.float32)
    if {"normals", "instance", "semantic"} & set(kinds):
        n_objects = len(scene.objects) if hasattr(scene, "objects") else len(scene)
        if n_objects > _MAX_INSTANCES:
            raise ParameterError(f"instance masks hold at most {_MAX_INSTANCES} objects (16-bit "
                                 f"PNG), the scene has {n_objects}; drop 'instance'/'semantic'")
        labels = renderer.render_labels(scene, pair.rig, eye="left")
        if "normals" in kinds:
            out["normals"] = labels.normals
        if "instance" in kinds:
            out["instance"] = labels.instance.astype(np.uint16)
        if "semantic" in kinds:
            out["semantic"] = semantic_lut(scene)[labels.instance]
    if "occlusion_right" in kinds:
        out["occlusion_right"] = right_occlusion_mask(pair.disp_left, pair.disp_right)
    return out
