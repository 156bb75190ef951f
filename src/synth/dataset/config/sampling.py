"""Per-sample randomness of a dataset: the sample seed, the drawn parameters and the scene.

Sample ``i`` of a dataset with seed ``s`` has the seed
``sample_seed(s, i) = SeedSequence(s, spawn_key=(i,)).generate_state(1, uint64)[0] >> 1``
(an int in ``[0, 2**63)``), and everything about the sample derives from that one integer through
independent streams ``SeedSequence(sample_seed, spawn_key=(k,))``: ``k = 0`` the parameter draws,
``1`` the preset's seed, ``2`` the occluders, ``3`` the photometric noise, ``4`` the materials,
lamps and relighting, ``5``/``6`` the photometric noise of ``im1E``/``im1L``, ``7`` the per-object
textures (the ``object_*`` keys, drawn for every object in scene order: kind, then photograph,
frequency, contrast, mean, angle where given, then the texture's seed), ``8`` the ``[rig]``
distributions (:mod:`synth.dataset.config.rig_draws`). Nothing depends on
which worker renders the sample, nor when.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from scenes import (
    LampSpec,
    LightSpec,
    MaterialSpec,
    ObjectSpec,
    Pose,
    SceneSpec,
    TextureSpec,
    get_preset,
)
from scenes.assets import list_mesh_folder, load_mesh_file
from scenes.materials import turn_lights
from scenes.posing import posed
from synth.camera.rig import StereoRig
from synth.dataset.config.parse import PER_OBJECT_KEYS, DatasetConfig
from synth.dataset.config.mix import STREAM_MIX
from synth.dataset.config.rig_draws import draw_rig
from synth.appearance.photometric import PhotometricParams
from synth.appearance.texture_control import retexture

__all__ = ["sample_seed", "redraw_seed", "pick_part", "stream", "SampleDraw", "draw_sample", "effective_frequency_px",
           "STREAM_PHOTOMETRIC", "STREAM_EXPOSURE_NOISE", "STREAM_LIGHTING_NOISE",
           "STREAM_TEXTURELESS"]

# The random streams of one sample (:func:`stream`), numbered once here for every user
# (drawing, the photometric noise of the dataset run and of validate's pairs).
(_STREAM_PARAMS, _STREAM_PRESET, _STREAM_OCCLUDERS, STREAM_PHOTOMETRIC, _STREAM_LIGHT,
 STREAM_EXPOSURE_NOISE, STREAM_LIGHTING_NOISE, _STREAM_TEXTURES) = range(8)
#: Stream 8 is the rig's (``rig_draws.STREAM_RIG``); 9 spawns the redraws' seeds.
_STREAM_REDRAW = 9
#: The order in which objects are made textureless (``textureless_area``). It shares the
#: exposure variant's stream (a permutation, and independent noise bits for ``im1E``, read
#: from the same generator state): kept so that existing datasets keep their bytes.
STREAM_TEXTURELESS = STREAM_EXPOSURE_NOISE
#: [scene] keys drawn per object or per lamp from the light stream, not once per sample.
_PER_ITEM = ("specular", "shininess", "specular_model", "roughness", "lamp_intensity",
             "lamp_shadows")
_PER_ITEM_DEFAULTS = {"specular": 0.5, "shininess": 32.0, "specular_model": "blinn-phong",
                      "roughness": 0.3, "lamp_intensity": 0.5, "lamp_shadows": True}
#: Occluder texture frequency (cycles per pixel) when the config sets none (as the presets: 8 px).
_DEFAULT_OCCLUDER_FREQUENCY_PX = 0.125


def sample_seed(dataset_seed: int, index: int) -> int:
    """The seed of sample ``index`` of a dataset with seed ``dataset_seed``.

    Examples
    --------
    >>> sample_seed(0, 0) == sample_seed(0, 0) != sample_seed(0, 1)
    True
    >>> 0 <= sample_seed(7, 3) < 2**63
    True
    """
    for name, value in (("dataset_seed", dataset_seed), ("index", index)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
            raise ValueError(f"{name} must be an int >= 0, got {value!r}")
    state = np.random.SeedSequence(int(dataset_seed), spawn_key=(int(index),))
    return int(state.generate_state(1, np.uint64)[0] >> np.uint64(1))


def stream(seed: int, k: int) -> np.random.Generator:
    """Independent generator number ``k`` of a sample seed.

    Examples
    --------
    >>> float(stream(5, 0).random()) == float(stream(5, 0).random()) != float(stream(5, 1).random())
    True
    """
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(int(k),)))


@dataclass(frozen=True)
class SampleDraw:
    """Everything drawn for one sample before rendering.

    Attributes
    ----------
    index, seed : int
    params : dict
        Drawn values, keys ``"scene.<key>"`` and ``"photometric.<key>"`` (plain JSON values).
    scene : SceneSpec
        Base preset, retextured, plus occluders (not yet matched to ``edge_density``).
    edge_density : float or None
        Target edge density of the closed-loop search, if the config asks for one.
    photometric : PhotometricParams
    exposure : float or None
        ``exposure_variant``: the linear exposure factor of ``im1E``, if asked for.
    relight : (LightSpec, tuple of LampSpec) or None
        ``lighting_variant``: the light and lamps ``im1L`` is rendered under, if asked for.
    rig : StereoRig
        The sample's rig: the configuration's, with its ``[rig]`` distributions drawn
        (:mod:`synth.dataset.config.rig_draws`).
    """

    index: int
    seed: int
    params: Mapping[str, Any]
    scene: SceneSpec
    edge_density: float | None
    photometric: PhotometricParams
    exposure: float | None = None
    relight: tuple[LightSpec, tuple[LampSpec, ...]] | None = None
    rig: StereoRig | None = None

    def __post_init__(self) -> None:
        if self.rig is None:
            raise TypeError("SampleDraw.rig: expected the sample's StereoRig, got None")


#: How a family occluder of extent ``side`` (metres) is sized: ``(rng, side) -> size``.
_FAMILY_SIZES = {
    "superquadric": lambda rng, side: tuple(side * rng.uniform(0.5, 1.0, size=3)),
    "furniture": lambda rng, side: (side * rng.uniform(0.5, 1.0), side,
                                    side * rng.uniform(0.4, 0.9)),
    "rock": lambda rng, side: (side / 2,),
    "polyhedron": lambda rng, side: (side / 2,),
    "torus": lambda rng, side: (side * 0.35, side * 0.35 * rng.uniform(0.1, 0.45)),
    "knot": lambda rng, side: (side / 2, side / 2 * rng.uniform(0.04, 0.125)),
    "revolution": lambda rng, side: (side * rng.uniform(0.2, 0.5), side),
    "extrusion": lambda rng, side: (side / 2, side * rng.uniform(0.1, 0.6)),
    "tree": lambda rng, side: (side * rng.uniform(0.5, 1.0), side),
    "bush": lambda rng, side: (side, side * rng.uniform(0.4, 0.8)),
    "wire": lambda rng, side: (side, side * rng.uniform(0.01, 0.04)),
}
#: ``occluder_deform``: the largest twist and bend (radians) and taper of a deformed occluder.
_DEFORM_ANGLE, _DEFORM_TAPER = np.pi / 4, 0.5


#: Drawn per occluder under ``occluder_each`` (from the occluder stream, in this order).
_EACH_KEYS = ("occluder_kind", "occluder_depth", "occluder_size")


def _occluder_each(config: DatasetConfig) -> bool:
    dist = config.scene.get("occluder_each")  # a fixed value (the parser refuses a draw)
    return dist is not None and bool(dist.args[0])


def _deformation(rng: np.random.Generator) -> tuple[float, float, float]:
    """One of twist, bend or taper, of a random sign and size up to the limits above."""
    which = int(rng.integers(0, 3))
    amount = float(rng.uniform(-1.0, 1.0)) * (_DEFORM_TAPER if which == 2 else _DEFORM_ANGLE)
    out = [0.0, 0.0, 0.0]
    out[which] = amount
    return (out[0], out[1], out[2])


def _occluders(draw: Mapping[str, Any], config: DatasetConfig, rig: StereoRig,
               rng: np.random.Generator, texture_kind: str | None) -> list[ObjectSpec]:
    draw_mesh = config.scene.get("occluder_mesh")
    each = _occluder_each(config)
    deform_chance = config.scene.get("occluder_deform")
    out = []
    f_px = draw.get("frequency_px") or _DEFAULT_OCCLUDER_FREQUENCY_PX
    for i in range(int(draw["occluders"])):
        if each:  # this occluder's own kind, depth and size
            draw = {**draw, **{k: config.scene[k].sample(rng) for k in _EACH_KEYS}}
        z = float(draw["occluder_depth"])
        u, v = rng.uniform(0.0, rig.width), rng.uniform(0.0, rig.height)
        x, y = (u - rig.cx) * z / rig.fx, (v - rig.cy) * z / rig.fy
        side = float(draw["occluder_size"]) * rig.width * z / rig.fx  # metres
        rotation = tuple(float(a) for a in rng.uniform(0.0, 360.0, size=3))
        kind = str(draw["occluder_kind"])
        path, seed = "", 0
        if kind == "mesh":  # scaled to a bounding-box diagonal of `side`, its box centred there
            path = str(draw_mesh.sample(rng))
            if os.path.isdir(path):  # a folder (ShapeNet, Objaverse): one of its files
                files = list_mesh_folder(path)
                path = files[int(rng.integers(len(files)))]
            data = load_mesh_file(path)
            lo, hi = data.vertices.min(axis=0), data.vertices.max(axis=0)
            scale = side / max(float(np.linalg.norm(hi - lo)), 1e-12)
            size = (scale,)
        elif kind in ("fence", "grid"):  # six bars across, 1.5 px thick (at least side / 40)
            thick = max(side / 40.0, 1.5 * z / rig.fx)
            size = (side, side, side / 6.0, min(thick, side / 12.0))
        elif kind in _FAMILY_SIZES:  # the shape is the seed's
            size = tuple(float(a) for a in _FAMILY_SIZES[kind](rng, side))
            seed = int(rng.integers(0, 2**63))
        else:
            size = {"box": (side, side, side), "sphere": (side / 2,),
                    "cylinder": (side / 2, side)}[kind]
        contrast = draw.get("contrast")
        texture = TextureSpec(
            kind=texture_kind or "noise", frequency=f_px * rig.fx / z,
            contrast=0.8 if contrast is None else float(contrast),
            mean=float(rng.uniform(0.3, 0.7)), seed=int(rng.integers(0, 2**63)),
            angle=float(rng.uniform(0.0, 180.0)))
        deform = (0.0, 0.0, 0.0)
        if deform_chance is not None and rng.random() < float(deform_chance.sample(rng)):
            deform = _deformation(rng)
        pose = Pose(translation=(x, y, z), rotation_deg=rotation)
        if path:
            shift = pose.rotation() @ ((lo + hi) / 2 * size[0])
            pose = Pose(translation=(x - shift[0], y - shift[1], z - shift[2]),
                        rotation_deg=rotation)
        out.append(ObjectSpec(kind, pose, size, texture, name=f"occluder{i}", segments=32,
                              path=path, seed=seed, deform=deform))
    return out


def _item(config: DatasetConfig, key: str, rng: np.random.Generator) -> Any:
    dist = config.scene.get(key)
    return _PER_ITEM_DEFAULTS[key] if dist is None else dist.sample(rng)


def _materials_and_lamps(scene: SceneSpec, draw: Mapping[str, Any], config: DatasetConfig,
                         rng: np.random.Generator) -> tuple[SceneSpec, dict[str, Any]]:
    """Specular materials per object and lamps per the [scene] keys, and how many objects
    became specular (the materials and lamps themselves are in the sample's scene.json)."""
    drawn: dict[str, Any] = {}
    fraction = draw.get("specular_fraction")
    if fraction:
        objects = []
        for obj in scene.objects:
            if rng.random() < fraction:
                material = MaterialSpec(float(_item(config, "specular", rng)),
                                        float(_item(config, "shininess", rng)),
                                        str(_item(config, "specular_model", rng)),
                                        float(_item(config, "roughness", rng)))
                obj = dataclasses.replace(obj, material=material)
            objects.append(obj)
        scene = dataclasses.replace(scene, objects=tuple(objects))
        drawn["specular_objects"] = sum(not o.material.is_matte() for o in objects)
    lamps = []
    z = float(np.median([o.pose.translation[2] for o in scene.objects]))
    centre = np.array([0.0, 0.0, z])
    for _ in range(int(draw.get("lamps") or 0)):
        intensity, shadows = float(_item(config, "lamp_intensity", rng)), bool(
            _item(config, "lamp_shadows", rng))
        if rng.random() < 0.5:  # from above the rig, toward the scene
            direction = (float(rng.uniform(-0.8, 0.8)), float(rng.uniform(0.2, 1.0)), 1.0)
            lamps.append(LampSpec("directional", direction=direction, intensity=intensity,
                                  shadows=shadows))
        else:  # above and around the rig, irradiance `intensity` at the scene centre
            pos = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.8, -0.3),
                            rng.uniform(0.0, 0.5)]) * z
            lamps.append(LampSpec("point", position=tuple(float(c) for c in pos),
                                  intensity=intensity * float(np.sum((pos - centre) ** 2)),
                                  shadows=shadows))
    if lamps:
        scene = dataclasses.replace(scene, lamps=tuple(lamps))
    return scene, drawn


def _object_textures(scene: SceneSpec, config: DatasetConfig, fx: float,
                     rng: np.random.Generator) -> SceneSpec:
    """Every object's texture drawn from the ``object_*`` keys (unset ones keep its own)."""
    dists = config.scene
    objects = []
    for obj in scene.objects:
        kind = str(dists["object_texture"].sample(rng))
        image = str(dists["object_image"].sample(rng)) if "object_image" in dists else ""
        t = obj.texture
        changes: dict[str, Any] = {"kind": kind, "image": image if kind == "image" else ""}
        if "object_frequency_px" in dists:
            f_px = float(dists["object_frequency_px"].sample(rng))
            changes["frequency"] = f_px * fx / obj.pose.translation[2]
        for key in ("contrast", "mean", "angle"):
            if f"object_{key}" in dists:
                changes[key] = float(dists[f"object_{key}"].sample(rng))
        changes["seed"] = int(rng.integers(0, 2**63))
        texture = TextureSpec(**{**{f: getattr(t, f) for f in t.__dataclass_fields__}, **changes})
        objects.append(dataclasses.replace(obj, texture=texture))
    return dataclasses.replace(scene, objects=tuple(objects))


def pick_part(config: DatasetConfig, index: int) -> tuple[int, DatasetConfig]:
    """The part of a mix (:mod:`synth.dataset.config.mix`) sample ``index`` is drawn from,
    under the mix's seed and ``redraw``, and its number; ``(-1, config)`` when it is no mix."""
    if not config.parts:
        return -1, config
    k = int(stream(sample_seed(config.seed, index), STREAM_MIX).integers(len(config.parts)))
    return k, dataclasses.replace(config.parts[k], seed=config.seed, redraw=config.redraw)


def redraw_seed(seed: int, attempt: int) -> int:
    """The seed of redraw ``attempt`` (>= 1) of a sample with seed ``seed`` (the configuration's
    ``redraw``): ``SeedSequence(seed, spawn_key=(9, attempt))``, an int in ``[0, 2**63)``.

    Examples
    --------
    >>> redraw_seed(5, 1) == redraw_seed(5, 1) != redraw_seed(5, 2)
    True
    """
    state = np.random.SeedSequence(int(seed), spawn_key=(_STREAM_REDRAW, int(attempt)))
    return int(state.generate_state(1, np.uint64)[0] >> np.uint64(1))


def draw_sample(config: DatasetConfig, index: int, *, attempt: int = 0) -> SampleDraw:
    """Draw sample ``index``'s parameters and build its scene.

    Every key of ``[scene]`` then ``[photometric]`` is drawn in schema order from the parameter
    stream (fixed values draw nothing), so a sample does not depend on any other. ``attempt``
    > 0 is the sample drawn again (a frame that taught nothing, ``redraw``): everything from
    :func:`redraw_seed` of its seed instead.

    Examples
    --------
    >>> from synth.dataset.config.parse import loads_config
    >>> cfg = loads_config('[scene]\\nfrequency_px = {uniform = [0.05, 0.1]}')
    >>> d = draw_sample(cfg, 3)
    >>> d == draw_sample(cfg, 3), 0.05 <= d.params["scene.frequency_px"] <= 0.1
    (True, True)
    """
    if config.parts:  # a mix: the part's sample, under the mix's seed
        _, part = pick_part(config, index)
        draw = draw_sample(part, index, attempt=attempt)
        return dataclasses.replace(draw, params={**draw.params, "mix.part": part.name})
    seed = sample_seed(config.seed, index)
    if attempt:
        seed = redraw_seed(seed, attempt)
    rig, rig_values = draw_rig(config.rig, config.rig_draws, seed,
                               fy_follows=config.rig.fy == config.rig.fx)
    rng = stream(seed, _STREAM_PARAMS)
    per_occluder = _EACH_KEYS if _occluder_each(config) else ()
    scene_draw = {k: d.sample(rng) for k, d in config.scene.items()
                  if k not in _PER_ITEM and k not in PER_OBJECT_KEYS and k not in per_occluder}
    phot_draw = {k: d.sample(rng) for k, d in config.photometric.items()}
    preset_seed = int(stream(seed, _STREAM_PRESET).integers(0, 2**63))
    scene = get_preset(str(scene_draw["base"]), seed=preset_seed)
    if "pitch" in rig_values or "camera_height" in rig_values:  # the rig's pose in the layout
        scene = posed(scene, camera_height=rig_values.get("camera_height"),
                      pitch=rig_values.get("pitch"))
    kind = None if scene_draw["texture"] == "preset" else str(scene_draw["texture"])
    extra = _occluders(scene_draw, config, rig, stream(seed, _STREAM_OCCLUDERS), kind)
    if extra:
        scene = SceneSpec(scene.name, (*extra, *scene.objects), light=scene.light,
                          background=scene.background, seed=scene.seed,
                          description=scene.description, sky=scene.sky)
    scene = retexture(scene, fx=rig.fx, frequency_px=scene_draw.get("frequency_px"),
                      contrast=scene_draw.get("contrast"), kind=kind)
    if "object_texture" in config.scene:
        scene = _object_textures(scene, config, rig.fx, stream(seed, _STREAM_TEXTURES))
    light_rng = stream(seed, _STREAM_LIGHT)
    scene, per_item = _materials_and_lamps(scene, scene_draw, config, light_rng)
    relight = None
    if scene_draw.get("lighting_variant") is not None:
        relight = turn_lights(scene, float(scene_draw["lighting_variant"]), light_rng)
    params = {f"scene.{k}": v for k, v in scene_draw.items()}
    params.update({f"scene.{k}": v for k, v in per_item.items()})
    params.update({f"photometric.{k}": v for k, v in phot_draw.items()})
    params["scene.preset_seed"] = preset_seed
    params.update({f"rig.{k}": v for k, v in rig_values.items()})
    return SampleDraw(index=int(index), seed=seed, params=params, scene=scene,
                      edge_density=scene_draw.get("edge_density"),
                      photometric=PhotometricParams.from_mapping(phot_draw),
                      exposure=scene_draw.get("exposure_variant"), relight=relight, rig=rig)


def effective_frequency_px(scene: SceneSpec, *, fx: float) -> float | None:
    """Median texture frequency of the scene's textured objects, cycles per pixel at each
    object's centre depth (``f_m * Z_ref / fx``); None if nothing is textured.

    Examples
    --------
    >>> effective_frequency_px(get_preset("fronto_plane"), fx=600.0)
    0.125
    """
    values = [o.texture.frequency * o.pose.translation[2] / fx for o in scene.objects
              if o.texture.kind != "constant" and o.texture.contrast > 0
              and o.pose.translation[2] > 0]
    return float(np.median(values)) if values else None
