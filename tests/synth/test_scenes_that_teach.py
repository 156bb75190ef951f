"""The families as dataset content: per-occluder draws, deformations, the floating and dense
configurations (determinism across workers, resume, verify) and the room layout."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import scenes
from scenes.layouts import room
from synth.dataset.compare import compare_datasets, summarize
from synth.dataset.config.parse import ConfigError, load_config, loads_config, resized
from synth.dataset.config.sampling import draw_sample
from synth.dataset.run import run_dataset

EACH = """\
seed = 3
[rig]
width = 96
height = 54
[scene]
base = "backdrop"
occluders = 12
occluder_each = true
occluder_kind = {choice = ["superquadric", "rock", "torus", "knot", "revolution", "extrusion",
                           "polyhedron", "tree", "bush", "wire", "furniture", "box"]}
occluder_size = {uniform = [0.05, 0.2]}
occluder_depth = {uniform = [5.0, 50.0]}
"""


def _occluders(draw) -> list[scenes.ObjectSpec]:
    return [o for o in draw.scene.objects if o.name.startswith("occluder")]


def test_occluder_each_draws_every_occluder_its_own_kind_depth_and_size():
    cfg = loads_config(EACH)
    draw = draw_sample(cfg, 0)
    occ = _occluders(draw)
    assert len(occ) == 12
    assert len({o.kind for o in occ}) >= 5  # 12 draws of 12 kinds
    assert len({o.pose.translation[2] for o in occ}) == 12
    assert all(5.0 <= o.pose.translation[2] <= 50.0 for o in occ)
    # a family's shape is its own seed's; nothing per-sample is recorded for the three keys
    assert len({o.seed for o in occ if o.kind in scenes.FAMILY_KINDS}) == sum(
        o.kind in scenes.FAMILY_KINDS for o in occ)
    assert not {"scene.occluder_kind", "scene.occluder_depth", "scene.occluder_size"} & set(
        draw.params)
    assert draw_sample(cfg, 0) == draw and draw_sample(cfg, 1) != draw
    # without the key every occluder shares the sample's draw, as before
    plain = draw_sample(loads_config(EACH.replace("occluder_each = true\n", "")), 0)
    assert len({o.pose.translation[2] for o in _occluders(plain)}) == 1
    assert "scene.occluder_depth" in plain.params


@pytest.mark.parametrize(("chance", "deformed"), [(0.0, 0), (1.0, 12)])
def test_occluder_deform_gives_one_of_twist_bend_taper_within_limits(chance, deformed):
    draw = draw_sample(loads_config(EACH + f"occluder_deform = {chance}\n"), 0)
    occ = _occluders(draw)
    assert sum(any(o.deform) for o in occ) == deformed
    for o in occ:
        twist, bend, taper = o.deform
        assert sum(v != 0 for v in o.deform) <= 1
        assert abs(twist) <= np.pi / 4 and abs(bend) <= np.pi / 4 and abs(taper) <= 0.5


def test_occluder_each_takes_one_value_not_a_draw():
    with pytest.raises(ConfigError, match="occluder_each.*true or false.*one value"):
        loads_config(EACH.replace("occluder_each = true", "occluder_each = {choice = [true, "
                                                          "false]}"))


def test_deform_is_checked_and_written_only_when_set():
    pose = scenes.Pose(translation=(0.0, 0.0, 3.0))
    obj = scenes.ObjectSpec("box", pose, (1.0, 1.0, 1.0), deform=[0.5, 0, 0])
    assert obj.deform == (0.5, 0.0, 0.0)
    assert "deform" in scenes.scene_to_dict(scenes.SceneSpec("s", (obj,)))["objects"][0]
    plain = dataclasses.replace(obj, deform=(0.0, 0.0, 0.0))
    assert "deform" not in scenes.scene_to_dict(scenes.SceneSpec("s", (plain,)))["objects"][0]
    assert scenes.scene_from_dict(scenes.scene_to_dict(scenes.SceneSpec("s", (obj,)))
                                  ).objects[0] == obj
    for bad, words in (((7.0, 0.0, 0.0), "twist"), ((0.0, 0.0, 0.95), "taper"),
                       ((0.0, 4.0, 0.0), "bend")):
        with pytest.raises(ValueError, match=f"deform {words}"):
            scenes.ObjectSpec("box", pose, (1.0, 1.0, 1.0), deform=bad)
    with pytest.raises(ValueError, match="deformed plane"):
        scenes.ObjectSpec("plane", pose, (1.0, 1.0), deform=(0.1, 0.0, 0.0))
    for kind, size, words in (("torus", (0.2, 0.2), "tube < radius"),
                              ("knot", (0.4, 0.07), r"tube <= 0.15 \* radius"),
                              ("wire", (0.1, 0.03), r"thickness <= 0.25 \* length")):
        with pytest.raises(ValueError, match=words):
            scenes.ObjectSpec(kind, pose, size)


def test_a_deformed_mesh_keeps_its_outline_closed_and_moves_as_asked():
    pose = scenes.Pose(translation=(0.0, 0.0, 3.0))
    box = scenes.ObjectSpec("box", pose, (0.2, 1.0, 0.2), deform=(0.0, 0.0, 0.5))
    mesh = scenes.build_mesh(box)
    v = np.asarray(mesh.vertices) - (0.0, 0.0, 3.0)
    top, bottom = v[np.isclose(v[:, 1], -0.5)], v[np.isclose(v[:, 1], 0.5)]
    # taper 0.5: the top (t = -1) half as wide, the bottom (t = +1) 1.5 times as wide
    assert np.abs(top[:, 0]).max() == pytest.approx(0.05)
    assert np.abs(bottom[:, 0]).max() == pytest.approx(0.15)
    import trimesh

    merged = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)
    assert merged.is_watertight and merged.volume > 0


def test_the_room_surrounds_the_rig_with_furniture_and_clutter():
    for seed in range(5):
        spec = room(seed)
        names = [o.name for o in spec.objects]
        assert names[:5] == ["floor", "ceiling", "back_wall", "left_wall", "right_wall"]
        furniture = [o for o in spec.objects if o.kind == "furniture"]
        assert 4 <= len(furniture) <= 9
        floor_y = spec.objects[0].pose.translation[1]
        for o in furniture:  # standing on the floor (its feet at local +y / 2)
            assert o.pose.translation[1] + o.size[1] / 2 == pytest.approx(floor_y, abs=1e-3)
        meshes = scenes.build_meshes(spec)
        z = np.concatenate([m.vertices[:, 2] for m in meshes])
        assert z.min() > 0.1  # everything ahead of the near plane


@pytest.fixture(scope="module")
def small_configs(tmp_path_factory) -> dict[str, Path]:
    """The shipped floating, dense and outdoor at 96 x 54 (fx scaled as `--size` does), 4
    samples, and a mix of the three naming their files beside it."""
    out = {}
    for name in ("floating", "dense", "outdoor"):
        text = (resources.files("synth.dataset") / "configs" / f"{name}.toml").read_text()
        text = text.replace("width = 960", "width = 96").replace("height = 540", "height = 54")
        text = text.replace("count = 100", "count = 4")
        text = text.replace("fx = {uniform = [700.0, 1100.0]}", "fx = {uniform = [70.0, 110.0]}")
        path = tmp_path_factory.mktemp(name) / f"{name}.toml"
        path.write_text(text)
        cfg = load_config(path)
        assert (cfg.rig.width, cfg.rig.fx, cfg.count) == (96, 90.0, 4)
        assert cfg.rig == resized(load_config(name), 96, 54).rig
        out[name] = path
    mix = out["floating"].parent.parent / "mix" / "mix.toml"
    mix.parent.mkdir()
    parts = ", ".join(f'"../{n}0/{n}.toml"' for n in ("floating", "dense", "outdoor"))
    mix.write_text(f'name = "mix"\ncount = 4\nredraw = 4\nmix = [{parts}]\n')
    out["mix"] = mix
    return out


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("name", ["floating", "dense", "outdoor", "mix"])
def test_new_configs_give_the_same_bytes_with_two_workers_and_verify(small_configs, name,
                                                                     tmp_path):
    from synth.dataset.config.parse import load_config as load

    cfg = load(small_configs[name])
    one, two = tmp_path / "one", tmp_path / "two"
    run_dataset(cfg, out=one, workers=1, progress=False)
    run_dataset(cfg, out=two, workers=2, progress=False)
    differences = compare_datasets(one, two)
    assert not differences, summarize(differences)
    cli = [sys.executable, "-c", "from synth.cli import main; main()"]
    run = subprocess.run(cli + ["dataset", "--verify", str(one)], capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("name", ["floating", "mix"])
def test_new_configs_resume_after_sigkill_with_the_same_bytes(small_configs, name, tmp_path,
                                                              sigkill_after_records):
    from synth.dataset.config.parse import load_config as load

    cfg = load(small_configs[name])
    reference = tmp_path / "ref"
    run_dataset(cfg, out=reference, workers=1, progress=False)
    out = tmp_path / "killed"
    cli = [sys.executable, "-c", "from synth.cli import main; main()"]
    proc = subprocess.Popen(cli + ["dataset", str(small_configs[name]), "--out", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    sigkill_after_records(proc, out, 1)
    assert proc.returncode != 0
    run = run_dataset(cfg, out=out, workers=1, progress=False)
    assert run.skipped >= 1 and run.rendered >= 1 and run.rendered + run.skipped == 4
    differences = compare_datasets(reference, out)
    assert not differences, summarize(differences)


@pytest.mark.gl
def test_the_contact_sheets_tile_every_family_and_config(tmp_path):
    from PIL import Image

    from synth.jobs.sheets import DEFORMED_EXAMPLES, config_sheet, family_sheet

    with Image.open(family_sheet(tmp_path / "f.png", width=40, height=30, seeds=(0,),
                                 columns=4)) as sheet:
        tiles = len(scenes.FAMILY_KINDS) + len(DEFORMED_EXAMPLES)
        assert sheet.size == (4 * (2 * 40 + 4), -(-tiles // 4) * (30 + 4))
        pixels = np.asarray(sheet)
    assert pixels[:30, :80].std() > 0  # a rendered tile, not a blank
    with Image.open(config_sheet(tmp_path / "c.jpg", ["floating"], count=2, width=48,
                                 height=27)) as sheet:
        assert sheet.size == (2 * (2 * 48 + 4), 27 + 4)


# --------------------------------------------------------------------------- the rig per sample
RIG = """\
seed = 5
[rig]
width = 64
height = 48
{rig}
[scene]
base = "flying"
occluders = 3
occluder_size = {{uniform = [0.1, 0.3]}}
"""


def test_a_drawn_baseline_and_focal_length_vary_per_sample_and_change_nothing_else():
    drawn = loads_config(RIG.format(rig="baseline = {uniform = [0.04, 0.4]}\n"
                                        "fx = {loguniform = [40.0, 80.0]}"))
    assert drawn.rig.baseline == pytest.approx(0.22) and drawn.rig.fx == pytest.approx(
        np.sqrt(40.0 * 80.0))  # the nominal rig: the middle of each draw
    rigs = [draw_sample(drawn, i).rig for i in range(20)]
    assert len({r.baseline for r in rigs}) == 20
    assert all(0.04 <= r.baseline <= 0.4 and 40.0 <= r.fx <= 80.0 and r.fy == r.fx for r in rigs)
    draw = draw_sample(drawn, 3)
    assert draw.params["rig.baseline"] == draw.rig.baseline
    assert draw.params["rig.fx"] == draw.rig.fx
    # the same scene draws as with fixed values: only the rig comes from its own stream
    fixed = loads_config(RIG.format(rig="baseline = 0.1"))
    a, b = draw_sample(fixed, 3), draw_sample(loads_config(
        RIG.format(rig="baseline = {uniform = [0.04, 0.4]}")), 3)
    assert a.scene == b.scene and a.photometric == b.photometric
    assert {k: v for k, v in b.params.items() if not k.startswith("rig.")} == a.params
    assert "rig.baseline" not in a.params and a.rig == fixed.rig
    # the configuration round-trips; --size scales the drawn focal length
    from synth.dataset.config.parse import config_from_dict

    assert config_from_dict(drawn.to_dict()) == drawn
    assert config_from_dict(drawn.to_dict()).hash() == drawn.hash()
    assert resized(drawn, 128, 96).to_dict()["rig"]["fx"] == {"loguniform": [80.0, 160.0]}


def test_only_baseline_fx_pitch_and_camera_height_may_be_drawn():
    with pytest.raises(ConfigError, match="rig.near.*fixed value"):
        loads_config(RIG.format(rig="near = {choice = [0.1, 0.2]}"))
    with pytest.raises(ConfigError, match=r"rig.baseline.uniform\[0\].*\(0.0, 100.0\]"):
        loads_config(RIG.format(rig="baseline = {uniform = [0.0, 0.4]}"))


def test_a_layout_refuses_a_drawn_rig_by_its_extremes(tmp_path):
    # fx = 60 px: the nominal baseline (2.55 m) fits CREStereo's 2048 px at the 0.1 m near
    # plane, the largest drawn one (5 m) does not: refused before anything is rendered
    text = RIG.format(rig="baseline = {uniform = [0.1, 5.0]}")
    with pytest.raises(ValueError, match="crestereo holds disparities up to"):
        run_dataset(loads_config(text), out=tmp_path / "d", fmt="crestereo", progress=False)
    assert not (tmp_path / "d").exists()


@pytest.mark.gl
def test_each_sample_writes_its_own_calibration(tmp_path):
    cfg = loads_config(RIG.format(rig="baseline = {uniform = [0.04, 0.4]}"))
    run_dataset(cfg, out=tmp_path / "d", count=3, progress=False)
    from matcher.io import read_calib

    for i in range(3):
        folder = tmp_path / "d" / "MiddEval3" / "trainingF" / f"{i:06d}"
        calib = read_calib(folder / "calib.txt")
        assert calib["baseline"] == pytest.approx(1000 * draw_sample(cfg, i).rig.baseline,
                                                  rel=1e-6)


# --------------------------------------------------------------------------- redraws
DARK = """\
seed = 2
redraw = 6
[rig]
width = 32
height = 24
[scene]
base = "boxes"
occluders = 2
occluder_depth = {choice = [0.05, 1.5, 1.5]}
[photometric]
gamma = {choice = [1.0, 1.0, 10.0]}
"""


@pytest.mark.gl
def test_frames_that_teach_nothing_are_drawn_again_the_same_way_each_time(tmp_path, renderer):
    from synth.dataset.sample import produce_sample, teaches_nothing

    cfg = loads_config(DARK)
    records = [produce_sample(cfg, i, renderer, tmp_path / f"s{i}", "middlebury")
               for i in range(8)]
    reasons = [r for rec in records for r in rec["stats"]["redrawn_for"]]
    # occluders nearer than the 0.1 m near plane, a gamma that darkens all: both redrawn
    assert {"depth range", "too dark"} <= set(reasons)
    for i, rec in enumerate(records):
        stats = rec["stats"]
        assert stats["redraws"] == len(stats["redrawn_for"]) <= 6
        if stats["redraws"]:  # the kept draw is the last one's: its seed and parameters
            assert rec["seed"] == draw_sample(cfg, i, attempt=stats["redraws"]).seed
        if stats["teaches_nothing"] is None:
            from PIL import Image

            folder = tmp_path / f"s{i}"
            with Image.open(folder / "im0.png") as im:
                left = np.asarray(im)
            with Image.open(folder / "mask0nocc.png") as im:
                mask = np.asarray(im)
            assert teaches_nothing(mask, left) is None
    again = produce_sample(cfg, 3, renderer, tmp_path / "again", "middlebury")
    assert again == records[3]
    # without the key nothing is redrawn and the stats hold no redraw entry
    plain = loads_config(DARK.replace("redraw = 6\n", "").replace(
        "occluder_depth = {choice = [0.05, 1.5, 1.5]}", "occluder_depth = 1.5"))
    rec = produce_sample(plain, 0, renderer, tmp_path / "plain", "middlebury")
    assert "redraws" not in rec["stats"]
    # a frame that stays useless is kept after the last redraw, and says so
    dark = loads_config(DARK.replace("gamma = {choice = [1.0, 1.0, 10.0]}", "gamma = 10.0")
                        .replace("occluder_depth = {choice = [0.05, 1.5, 1.5]}",
                                 "occluder_depth = 1.5"))
    stats = produce_sample(dark, 0, renderer, tmp_path / "dark", "middlebury")["stats"]
    assert stats["redraws"] == 6 and stats["redrawn_for"] == ["too dark"] * 6
    assert stats["teaches_nothing"] == "too dark"


def test_a_folder_of_meshes_is_an_occluder_kind(tmp_path):
    import trimesh

    for i, sub in enumerate(("a/models", "b", "b/deeper")):
        (tmp_path / "meshes" / sub).mkdir(parents=True, exist_ok=True)
        trimesh.creation.box(extents=(1.0, 1.0 + i, 1.0)).export(
            tmp_path / "meshes" / sub / f"m{i}.obj")
    (tmp_path / "meshes" / "notes.txt").write_text("not a mesh")
    text = EACH.replace('occluder_kind = {choice = ["superquadric", "rock", "torus", "knot", '
                        '"revolution", "extrusion",\n                           "polyhedron", '
                        '"tree", "bush", "wire", "furniture", "box"]}',
                        f'occluder_kind = "mesh"\noccluder_mesh = "{tmp_path / "meshes"}"')
    text = text.replace("occluder_size = {uniform = [0.05, 0.2]}", "occluder_size = 0.1")
    cfg = loads_config(text)
    paths = {o.path for i in range(4) for o in _occluders(draw_sample(cfg, i))}
    assert paths == {str(p) for p in sorted((tmp_path / "meshes").rglob("*.obj"))}
    from scenes.assets import load_mesh_file

    for o in _occluders(draw_sample(cfg, 0)):  # normalised: bounding-box diagonal = its size
        v = load_mesh_file(o.path).vertices
        # the drawn point (the box centre) is at the pose's translation plus the centre's shift
        centre_z = (o.pose.rotation() @ ((v.min(axis=0) + v.max(axis=0)) / 2 * o.size[0]))[2]
        side = 0.1 * cfg.rig.width * (o.pose.translation[2] + centre_z) / cfg.rig.fx
        diagonal = np.linalg.norm(v.max(axis=0) - v.min(axis=0)) * o.size[0]
        assert diagonal == pytest.approx(side, rel=1e-9)
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match="occluder_mesh.*holds no mesh file"):
        loads_config(text.replace(str(tmp_path / "meshes"), str(tmp_path / "empty")))


# --------------------------------------------------------------------------- mix
def test_a_mix_draws_each_sample_from_one_part_as_that_part_does():
    import dataclasses as dc

    mix = load_config("mix")
    assert [p.name for p in mix.parts] == ["floating", "dense", "outdoor"]
    picked = [draw_sample(mix, i).params["mix.part"] for i in range(60)]
    counts = {name: picked.count(name) for name in ("floating", "dense", "outdoor")}
    assert all(8 <= n <= 32 for n in counts.values()), counts  # about a third each
    for i in range(6):
        draw = draw_sample(mix, i)
        part = next(p for p in mix.parts if p.name == draw.params["mix.part"])
        alone = draw_sample(dc.replace(part, seed=mix.seed, redraw=mix.redraw), i)
        assert draw.scene == alone.scene and draw.rig == alone.rig
        assert {k: v for k, v in draw.params.items() if k != "mix.part"} == alone.params


def test_a_mix_is_refused_with_tables_nesting_or_two_sizes(tmp_path):
    with pytest.raises(ConfigError, match="no table beside mix"):
        loads_config('mix = ["floating"]\n[scene]\nbase = "boxes"\n')
    (tmp_path / "m.toml").write_text('mix = ["floating"]\n')
    with pytest.raises(ConfigError, match="is a mix itself"):
        loads_config(f'mix = ["{tmp_path / "m.toml"}"]', source=str(tmp_path / "n.toml"))
    with pytest.raises(ConfigError, match="one image size, got 640x480, 960x540"):
        loads_config('mix = ["flying", "floating"]')
    with pytest.raises(ConfigError, match="non-empty array"):
        loads_config("mix = []")
    # --size renders every part at the size asked
    assert {(p.rig.width, p.rig.height) for p in resized(load_config("mix"), 96, 54).parts} == {
        (96, 54)}


def test_outdoor_things_stand_on_the_ground_and_nothing_leaves_near_far():
    import trimesh

    from scenes.layouts import outdoor

    for seed in range(4):
        spec = outdoor(seed)
        standing = [o for o in spec.objects if o.kind in ("tree", "bush", "rock")]
        assert len(standing) >= 22
        meshes = dict(zip((o.name for o in spec.objects), scenes.build_meshes(spec)))
        ground = meshes["ground"]
        ground = trimesh.Trimesh(ground.vertices, ground.faces, process=False)
        origins = np.array([[o.pose.translation[0], -100.0, o.pose.translation[2]]
                            for o in standing])
        hits, rays, _ = ground.ray.intersects_location(
            origins, np.tile([0.0, 1.0, 0.0], (len(standing), 1)), multiple_hits=False)
        below = dict(zip(rays, hits[:, 1]))  # the ground's y under each (y down)
        assert len(below) == len(standing)
        for r, o in enumerate(standing):
            lowest = meshes[o.name].vertices[:, 1].max()
            assert lowest >= below[r] - 0.01, f"{o.name} floats {below[r] - lowest:.3f} m above"
        zs = np.concatenate([m.vertices[:, 2] for m in meshes.values()])
        assert 0.1 < zs.min() and zs.max() < 100.0
