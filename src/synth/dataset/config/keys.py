"""Every key of a dataset configuration: its sections, types, defaults, bounds and docs.

The schema (:data:`SCHEMA`) that :mod:`synth.dataset.config.parse` parses and ``docs/datasets.md``
documents key by key, with the value lists it refers to. Data only: no parsing here.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Mapping

from scenes import PRESETS
from scenes.materials import MAX_LAMPS, SPECULAR_MODELS
from scenes.spec import FAMILY_KINDS
from stereoforge.schema import Key
from synth.camera.lens import F_SCALE_RANGE, MAX_ROTATION_DEG

__all__ = ["SCHEMA", "EXAMPLES", "PER_OBJECT_KEYS", "DIST_KINDS", "DIST_SECTIONS", "DIST_FORMS",
           "DISTORTION_KEYS", "IDEAL_RIG_KEYS", "POSE_RIG_KEYS", "GROUND_TRUTH_KINDS", "MAX_SEED",
           "SCENE_TEXTURES", "OCCLUDER_KINDS", "OBJECT_TEXTURES", "IMAGE_DEFLATES",
           "allowed_values"]

MAX_SEED = 2**63
DIST_KINDS = ("uniform", "loguniform", "choice")
DIST_SECTIONS = ("scene", "photometric")  # their keys may be distributions
DIST_FORMS = "{uniform=[a,b]}, {loguniform=[a,b]}, {choice=[...]}"


def allowed_values(section: str, spec: Key) -> str:
    """What a key of ``section`` takes: its values, and the distributions if it may be one."""
    if section not in DIST_SECTIONS:
        return spec.expected()
    forms = DIST_FORMS if spec.kind in ("float", "int") else "{choice=[...]}"
    return f"{spec.expected()} (or {forms})"


SCENE_TEXTURES = ("preset", "noise", "checker", "stripes", "constant")
DISTORTION_KEYS = ("k1", "k2", "p1", "p2", "k3")
#: The ``[rig]`` keys of the ideal rig (always written by
#: :meth:`synth.dataset.config.parse.DatasetConfig.to_dict`).
IDEAL_RIG_KEYS = ("width", "height", "fx", "baseline", "near", "far")
#: ``[rig]`` keys of the rig's pose in its layout (:mod:`scenes.posing`), not of its cameras.
POSE_RIG_KEYS = ("camera_height", "pitch")
# synth.write.extra_ground_truth.GROUND_TRUTH (not imported: it loads the writers; a test checks they
# agree)
GROUND_TRUTH_KINDS = ("depth", "normals", "instance", "semantic", "occlusion_right")
# matcher.io.png.DEFLATES (not imported: data only here; a test checks they agree)
IMAGE_DEFLATES = ("isal", "libdeflate", "zlib", "stored")
OCCLUDER_KINDS = ("box", "sphere", "cylinder", "fence", "grid", "mesh", *FAMILY_KINDS)
OBJECT_TEXTURES = ("noise", "checker", "stripes", "constant", "image")
#: ``[scene]`` keys drawn once per object or occluder (``synth.dataset.config.sampling``), not per
#: sample.
PER_OBJECT_KEYS = ("occluder_mesh", "occluder_deform", "object_texture",
                   "object_image", "object_frequency_px", "object_contrast", "object_mean",
                   "object_angle")

#: Every section, key and its schema (``""`` is the top level).
SCHEMA: Mapping[str, Mapping[str, Key]] = MappingProxyType({
    "": {
        "name": Key("str", "dataset", doc="dataset name"),
        "seed": Key("int", 0, lo=0, hi=MAX_SEED - 1, doc="dataset seed"),
        "count": Key("int", 10, lo=1, hi=999_999, doc="number of samples"),
        "preview": Key("bool", False, doc="also write preview.png per sample"),
        "mix": Key("str", None, array=True,
                   doc="a mix: configuration names, .toml paths or tables, each sample drawn "
                       "from one (synth.dataset.config.mix); no [rig], [scene], [photometric]"),
        "redraw": Key("int", None, lo=0, hi=32,
                      doc="draw a sample again (its next sub-seed), at most this many times, "
                          "while its frame teaches nothing: over 95 % of pixels without ground "
                          "truth, a mean grey level under 15, or geometry outside [near, far]"),
        "ground_truth": Key("str", None, choices=GROUND_TRUTH_KINDS, array=True, distinct=True,
                            doc="optional ground truth to write too "
                                "(see synth.write.extra_ground_truth)"),
        "image_deflate": Key("str", None, choices=IMAGE_DEFLATES,
                             doc="deflate of the images' PNGs (matcher.io.encode_png; unset: "
                                 "ISA-L, zlib without it); stored: no compression, ~1.5x "
                                 "larger images, ~5 ms less per 960x540 image, bytes fixed by "
                                 "the pixels alone; not for the JPEG layouts"),
    },
    "rig": {
        "width": Key("int", 640, lo=8, hi=8192, doc="image width, pixels"),
        "height": Key("int", 480, lo=8, hi=8192, doc="image height, pixels"),
        "fx": Key("float", None, lo=0.0, lo_open=True,
                  doc="focal length in pixels; default 600 * width / 640"),
        "baseline": Key("float", 0.1, lo=0.0, lo_open=True, hi=100.0,
                        doc="baseline, metres"),
        "near": Key("float", 0.1, lo=0.0, lo_open=True, doc="near plane, metres"),
        "far": Key("float", 100.0, lo=0.0, lo_open=True, doc="far plane, metres"),
        # the real cameras (synth.camera.lens.RigErrors); unset = the ideal rig, today's bytes
        "fy": Key("float", None, lo=0.0, lo_open=True, doc="vertical focal length, pixels"),
        **{f"{side}{k}": Key("float", None, lo=-2.0 if k[0] == "k" else -0.05,
                             hi=2.0 if k[0] == "k" else 0.05,
                             doc=f"{'right' if side else 'left'} camera distortion {k} (OpenCV)")
           for side in ("", "right_") for k in DISTORTION_KEYS},
        **{f"right_{a}_deg": Key("float", None, lo=-MAX_ROTATION_DEG, hi=MAX_ROTATION_DEG,
                                 doc=f"rotation of the right camera about its {a[1]} axis, degrees")
           for a in ("rx", "ry", "rz")},
        "right_dy_px": Key("float", None, lo=-64.0, hi=64.0,
                           doc="vertical offset of the right principal point, pixels"),
        "right_f_scale": Key("float", None, lo=F_SCALE_RANGE[0], hi=F_SCALE_RANGE[1],
                             doc="right focal lengths over the left's"),
        "focus_distance": Key("float", None, lo=0.0, lo_open=True,
                              doc="defocus: in-focus depth, metres (unset: no defocus)"),
        "f_number": Key("float", None, lo=0.5, hi=64.0, doc="defocus: f-number"),
        "pixel_pitch_um": Key("float", None, lo=0.1, hi=100.0,
                              doc="defocus: pixel pitch, micrometres (default 3)"),
        # the rig's pose in its layout (scenes.posing); unset = the layout's own, today's bytes
        "camera_height": Key("float", None, lo=0.05, hi=100.0,
                             doc="cameras above the base's floor (room, outdoor), metres"),
        "pitch": Key("float", None, lo=-45.0, hi=45.0,
                     doc="rig turned about its baseline, degrees; positive looks down"),
    },
    "scene": {
        "base": Key("str", "fronto_plane", choices=tuple(PRESETS), doc="base preset"),
        "texture": Key("str", "preset", choices=SCENE_TEXTURES,
                       doc="texture kind of every object ('preset' keeps the preset's)"),
        "frequency_px": Key("float", None, lo=0.0, lo_open=True, hi=0.5,
                            doc="texture frequency, cycles per pixel at each object's depth"),
        "contrast": Key("float", None, lo=0.0, hi=1.0, doc="texture contrast"),
        "edge_density": Key("float", None, lo=0.005, hi=0.45,
                            doc="target Canny edge density of the left image (closed loop)"),
        "occluders": Key("int", 0, lo=0, hi=256, doc="number of occluding objects added"),
        "occluder_size": Key("float", 0.15, lo=0.0, lo_open=True, hi=1.0,
                             doc="occluder size, fraction of the image width"),
        "occluder_depth": Key("float", 1.5, lo=0.0, lo_open=True,
                              doc="occluder centre depth, metres"),
        "occluder_kind": Key("str", "box", choices=OCCLUDER_KINDS, doc="occluder shape"),
        "occluder_each": Key("bool", None,
                             doc="draw occluder_kind, occluder_size and occluder_depth per "
                                 "occluder (unset: once per sample, all occluders alike)"),
        "occluder_deform": Key("float", None, lo=0.0, hi=1.0,
                               doc="chance of each occluder to be twisted, bent or tapered (one "
                                   "of the three, up to pi/4 rad or 0.5)"),
        # materials and light (all unset: matte scenes under the preset's light, as before)
        "specular_fraction": Key("float", None, lo=0.0, hi=1.0,
                                 doc="chance of each object to get a specular material"),
        "specular": Key("float", None, lo=0.0, hi=16.0,
                        doc="specular strength of a specular object, drawn per object"),
        "shininess": Key("float", None, lo=1.0, hi=10_000.0,
                         doc="Blinn-Phong exponent of a specular object, drawn per object"),
        "specular_model": Key("str", None, choices=SPECULAR_MODELS,
                              doc="specular lobe of a specular object, drawn per object"),
        "roughness": Key("float", None, lo=0.02, hi=1.0,
                         doc="GGX roughness of a specular object, drawn per object"),
        "lamps": Key("int", None, lo=0, hi=MAX_LAMPS, doc="number of lamps added"),
        "lamp_intensity": Key("float", None, lo=0.0, hi=100.0,
                              doc="irradiance of each lamp at the scene centre, drawn per lamp"),
        "lamp_shadows": Key("bool", None, doc="lamps cast shadows (drawn per lamp)"),
        "exposure_variant": Key("float", None, lo=0.0, lo_open=True, hi=16.0,
                                doc="im1E: linear exposure factor of the right view"),
        "lighting_variant": Key("float", None, lo=0.0, hi=180.0,
                                doc="im1L: degrees the light directions turn for the right view"),
        "occluder_mesh": Key("str", None, doc="mesh file of 'mesh' occluders (OBJ, PLY, STL, "
                             "GLB, ...) or a folder of them (subfolders included), drawn per "
                             "occluder"),
        "object_texture": Key("str", None, choices=OBJECT_TEXTURES,
                              doc="texture kind, drawn per object (repeat a choice to weight it)"),
        "object_image": Key("str", None, doc="photograph of an 'image' texture, drawn per "
                            "object: skimage:<name>, a file or a folder"),
        "object_frequency_px": Key("float", None, lo=0.0, lo_open=True, hi=0.5,
                                   doc="texture frequency per object, cycles per pixel at its "
                                       "depth (of a photograph: its mean frequency)"),
        "object_contrast": Key("float", None, lo=0.0, hi=1.0, doc="texture contrast per object"),
        "object_mean": Key("float", None, lo=0.0, hi=1.0, doc="texture mean grey per object"),
        "object_angle": Key("float", None, doc="texture angle per object, degrees"),
        "textureless_area": Key("float", None, lo=0.0, hi=1.0,
                                doc="target share of the left image showing constant-textured "
                                    "objects (measured, synth.appearance.textureless)"),
    },
    "photometric": {
        "noise_sigma": Key("float", 0.0, lo=0.0, hi=64.0,
                           doc="Gaussian noise standard deviation, grey levels (0..255)"),
        "gain": Key("float", 1.0, lo=0.0, lo_open=True, hi=4.0,
                    doc="gain of the right image relative to the left"),
        "bias": Key("float", 0.0, lo=-128.0, hi=128.0,
                    doc="bias of the right image relative to the left, grey levels"),
        "gamma": Key("float", 1.0, lo=0.1, hi=10.0, doc="gamma applied to both images"),
        "blur_sigma": Key("float", 0.0, lo=0.0, hi=16.0,
                          doc="Gaussian blur standard deviation, pixels, both images"),
        "jpeg_quality": Key("int", 0, lo=0, hi=100, doc="JPEG round trip quality, 0 = off"),
    },
})

#: Shipped example configurations (``src/synth/dataset/configs/<name>.toml``).
EXAMPLES = ("planes", "texture-sweep", "flying", "imperfect-rig", "middlebury-like", "floating",
            "dense", "outdoor", "mix")
