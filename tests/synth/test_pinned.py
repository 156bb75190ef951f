"""Pins what nothing else pins: calib.txt as written, manifest statistics recomputed from the
files, the blur's border mode, and the occluders' texture frequency against their depth."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from matcher.io import read_calib, read_image, read_pfm
from scenes import scene_from_dict
from synth.dataset.config.parse import loads_config
from synth.dataset.run import read_manifest, run_dataset
from synth.dataset.config.sampling import draw_sample, effective_frequency_px
from synth.appearance.photometric import PhotometricParams, apply_photometric
from synth.appearance.texture_control import edge_density

_TINY = """\
name = "pinned"
seed = 5
count = 4

[rig]
width = 48
height = 32
baseline = 0.12

[scene]
base = {choice = ["fronto_plane", "slanted_plane", "boxes", "flying"]}
occluders = {uniform = [0, 2]}
occluder_depth = {uniform = [1.0, 1.5]}
"""


def _check_calib(folder: Path) -> None:
    """calib.txt of one written pair against its own disparities and rig."""
    calib = read_calib(folder / "calib.txt")
    rig = json.loads((folder / "scene.json").read_text())["rig"]
    d0, d1 = read_pfm(folder / "disp0GT.pfm"), read_pfm(folder / "disp1GT.pfm")
    finite = np.concatenate([d0[np.isfinite(d0)], d1[np.isfinite(d1)]])
    assert finite.size > 0
    lo, hi = float(finite.min()), float(finite.max())
    assert calib["vmin"] <= lo <= hi <= calib["vmax"]
    assert (calib["vmin"], calib["vmax"]) == (math.floor(lo), math.ceil(hi))  # tight bounds
    assert calib["ndisp"] % 16 == 0 and calib["vmax"] < calib["ndisp"] <= calib["vmax"] + 16
    assert calib["baseline"] == pytest.approx(rig["baseline"] * 1000.0)  # millimetres
    assert calib["doffs"] == 0.0  # one principal point for both views
    assert (calib["width"], calib["height"]) == (d0.shape[1], d0.shape[0])
    assert (calib["width"], calib["height"]) == (rig["width"], rig["height"])
    for cam in ("cam0", "cam1"):
        k = np.asarray(calib[cam])
        assert k[0, 0] == pytest.approx(rig["fx"]) and k[1, 1] == pytest.approx(rig["fy"])
        assert (k[0, 2], k[1, 2]) == pytest.approx((rig["cx"], rig["cy"]))


# the default focal length, and a wide one (fx = 24 px) that shows the empty background: both
# occluded (mask 128) and invalid (mask 0) pixels occur, so neither statistic stands for the other
@pytest.fixture(scope="module", params=["", "fx = 24\n"], ids=["default-fx", "wide"])
def tiny(request, tmp_path_factory, renderer) -> Path:
    out = tmp_path_factory.mktemp("pinned") / "ds"
    text = _TINY.replace("baseline = 0.12\n", "baseline = 0.12\n" + request.param)
    run_dataset(loads_config(text), out=out, progress=False)
    return out


@pytest.mark.gl
def test_calib_txt_written_by_dataset(tiny):
    for i in range(4):
        _check_calib(tiny / "MiddEval3" / "trainingF" / f"{i:06d}")


@pytest.mark.gl
def test_calib_txt_written_by_render(tmp_path, renderer):
    from click.testing import CliRunner

    from synth.cli import main

    for preset in ("slanted_plane", "boxes"):
        out = tmp_path / preset
        result = CliRunner().invoke(main, ["render", preset, "--out", str(out), "--width", "64",
                                           "--height", "48"], catch_exceptions=False)
        assert result.exit_code == 0, result.output
        _check_calib(out)


@pytest.mark.gl
def test_manifest_statistics_equal_the_files(tiny):
    records = read_manifest(tiny)
    assert len(records) == 4 and {r["params"]["scene.base"] for r in records} != set()
    scenes = tiny / "MiddEval3" / "trainingF"
    fx = json.loads((scenes / "000000" / "scene.json").read_text())["rig"]["fx"]
    for r in records:
        folder = scenes / r["dir"]
        disp, mask = read_pfm(folder / "disp0GT.pfm"), read_image(folder / "mask0nocc.png")
        finite = disp[np.isfinite(disp)]
        s = r["stats"]
        assert s["disp_min"] == round(float(finite.min()), 6)
        assert s["disp_max"] == round(float(finite.max()), 6)
        assert s["occluded_fraction"] == round(float(np.mean(mask == 128)), 6)
        assert s["invalid_fraction"] == round(float(np.mean(mask == 0)), 6)
        # no photometric model here: the stored left image is the one the statistic measured
        assert s["edge_density"] == round(edge_density(read_image(folder / "im0.png")), 6)
        scene = scene_from_dict(json.loads((folder / "scene.json").read_text())["scene"])
        assert s["texture_frequency_px"] == round(effective_frequency_px(scene, fx=fx), 6)
    # the manifest files hold exactly these records
    lines = (tiny / "manifest.jsonl").read_text().splitlines()
    assert [json.loads(line) for line in lines] == records
    assert any(r["stats"]["occluded_fraction"] > 0 for r in records)
    if fx == 24:  # the wide rig
        assert all(r["stats"]["invalid_fraction"] > 0.3 for r in records)


def _gauss(sigma: float) -> np.ndarray:
    k = 2 * math.ceil(3 * sigma) + 1
    x = np.arange(k) - k // 2
    w = np.exp(-0.5 * (x / sigma) ** 2)
    return w / w.sum()


def test_blur_reflects_the_border_on_a_ramp():
    """A horizontal ramp blurred with `dcb|abcd|cba` borders (OpenCV's REFLECT_101)."""
    sigma, width = 1.5, 40
    ramp = np.tile((np.arange(width) * 6).astype(np.uint8), (12, 1))
    img = np.repeat(ramp[..., None], 3, axis=2)
    out = apply_photometric(img, img, PhotometricParams(blur_sigma=sigma), rng=0).left
    w = _gauss(sigma)
    expected = {mode: np.convolve(np.pad(ramp[0].astype(float), len(w) // 2, mode=mode), w,
                                  mode="valid") for mode in ("reflect", "symmetric", "edge")}
    got = out[6, :, 0].astype(float)
    assert np.all(np.abs(got - expected["reflect"]) <= 1)  # rounding of OpenCV's fixed point
    # the interior of a ramp is unchanged by any symmetric blur; the borders tell the modes apart
    assert np.array_equal(got[5:-5], ramp[0, 5:-5])
    for other in ("symmetric", "edge"):
        assert np.abs(got[:2] - expected[other][:2]).max() > 1.5, other
    assert np.array_equal(out[:, :, 0], out[:, :, 2])  # the same blur on every row and channel


@pytest.mark.parametrize("frequency_px", [None, 0.08])
def test_occluder_texture_frequency_scales_with_depth(frequency_px):
    """At depth Z an occluder's texture has f_px * fx / Z cycles per metre: f_px at any depth."""
    extra = "" if frequency_px is None else f"frequency_px = {frequency_px}\n"
    want = 0.125 if frequency_px is None else frequency_px  # the default: the presets' 8 px
    seen = []
    for depth in (0.8, 1.6, 3.2):
        cfg = loads_config(f"[rig]\nfx = 500\n[scene]\n{extra}occluders = 2\n"
                           f"occluder_depth = {depth}\n")
        scene = draw_sample(cfg, 0).scene
        occluders = [o for o in scene.objects if o.name.startswith("occluder")]
        assert len(occluders) == 2
        for o in occluders:
            assert o.pose.translation[2] == pytest.approx(depth)
            assert o.texture.frequency == pytest.approx(want * 500 / depth)
            seen.append(o.texture.frequency)
    assert seen[0] == pytest.approx(4 * seen[-1])  # 4x farther: 4x fewer cycles per metre


@pytest.mark.gl
def test_manifest_csv_spells_every_record_cell(tmp_path, renderer):
    """manifest.csv: one row per record, ``true``/``false``, empty for None, repr of floats."""
    import csv

    cfg = loads_config("count = 2\n[rig]\nwidth = 64\nheight = 48\n[scene]\n"
                       'base = "fronto_plane"\ntexture = "noise"\n'
                       "edge_density = {uniform = [0.1, 0.2]}\n")
    out = tmp_path / "ds"
    run_dataset(cfg, out=out, progress=False)
    records = read_manifest(out)
    rows = list(csv.DictReader((out / "manifest.csv").read_text().splitlines()))
    assert len(rows) == len(records) == 2

    def spelt(value) -> str:
        if value is None:
            return ""
        if isinstance(value, bool):
            return {True: "true", False: "false"}[value]
        return repr(value) if isinstance(value, float) else str(value)

    for row, r in zip(rows, records):
        want = {"index": str(r["index"]), "seed": str(r["seed"]), "dir": r["dir"],
                **{f"params.{k}": spelt(v) for k, v in r["params"].items()},
                **{f"stats.{k}": spelt(v) for k, v in r["stats"].items()}}
        assert row == want
    assert {row["stats.edge_search_converged"] for row in rows} <= {"true", "false"}


@pytest.mark.parametrize("top, vmax, ndisp", [(31.5, 32, 48), (32.0, 32, 48), (15.2, 16, 32),
                                              (14.0, 14, 16)])
def test_calib_ndisp_is_above_vmax_also_on_a_multiple_of_16(top, vmax, ndisp):
    """ndisp = vmax + 1 rounded up to a multiple of 16: d = vmax must be searched."""
    from types import SimpleNamespace

    from synth.write.export import calib_for
    from synth.camera.rig import StereoRig

    disp = np.array([[np.inf, 3.25, top]], np.float32)
    rig = StereoRig(width=3, height=1, fx=100.0, fy=100.0, cx=1.0, cy=0.0, baseline=0.1)
    pair = SimpleNamespace(disp_left=disp, disp_right=disp[:, ::-1], rig=rig)
    calib = calib_for(pair)
    assert (calib["vmin"], calib["vmax"], calib["ndisp"]) == (3, vmax, ndisp)
