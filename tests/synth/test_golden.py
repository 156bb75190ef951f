"""Golden references: the exact matcher check (fast, no GL) and the render check (GL)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from matcher.io import encode_png, read_image, read_pfm, write_pfm
from synth.jobs.golden_compare import compare_render
from synth.jobs.golden import (
    GOLDEN_CASES,
    GOLDEN_SCENES,
    TOLERANCES,
    format_changes,
    golden_check,
    golden_update,
)

GOLDEN = Path(__file__).resolve().parents[2] / "golden"


def _one_scene_copy(tmp_path: Path, scene: str = "boxes") -> Path:
    """A copy of the golden folder reduced to one scene (keeps the test fast)."""
    root = tmp_path / "golden"
    shutil.copytree(GOLDEN / scene, root / scene)
    manifest = json.loads((GOLDEN / "manifest.json").read_text())
    manifest["scenes"] = [s for s in manifest["scenes"] if s["name"] == scene]
    (root / "manifest.json").write_text(json.dumps(manifest))
    return root


def test_manifest_records_seeds_versions_and_gl():
    manifest = json.loads((GOLDEN / "manifest.json").read_text())
    assert [(s["preset"], s["seed"]) for s in manifest["scenes"]] == list(GOLDEN_SCENES)
    assert {"stereoforge", "numpy", "opencv-python-headless", "numba"} <= set(manifest["versions"])
    assert manifest["gl"]["GL_RENDERER"] and manifest["gl"]["GL_VERSION"]
    assert [(c["method"], c["window"]) for c in manifest["cases"]] == list(GOLDEN_CASES)
    methods = {m for m, _ in GOLDEN_CASES}
    assert methods == {"ct", "sct", "cthw", "awct", "awsct", "bm", "sgbm"}


def test_golden_folder_is_small_and_hashes_match():
    import hashlib

    total = sum(p.stat().st_size for p in GOLDEN.rglob("*") if p.is_file())
    assert total <= 5_000_000
    manifest = json.loads((GOLDEN / "manifest.json").read_text())
    for rel, digest in manifest["sha256"].items():
        assert hashlib.sha256((GOLDEN / rel).read_bytes()).hexdigest() == digest, rel


def test_matcher_outputs_match_golden_exactly():
    report = golden_check(GOLDEN, render=False)
    assert report.failures == ()
    assert report.ok
    assert report.matcher_cases == len(GOLDEN_SCENES) * len(GOLDEN_CASES)


def test_tampered_metric_fails_naming_the_file(tmp_path):
    root = _one_scene_copy(tmp_path)
    path = root / "boxes" / "expected" / "metrics.json"
    metrics = json.loads(path.read_text())
    metrics["ct-w5"]["all"]["pobmp"] += 1e-9
    path.write_text(json.dumps(metrics))
    report = golden_check(root, render=False)
    assert not report.ok
    assert len(report.failures) == 1
    assert report.failures[0].startswith("boxes/expected/metrics.json: ct-w5.all.pobmp")


def test_tampered_disparity_fails_naming_the_file(tmp_path):
    root = _one_scene_copy(tmp_path)
    path = root / "boxes" / "expected" / "sgbm-w9.pfm"
    disp = read_pfm(path).copy()
    disp[10, 10] = disp[10, 10] + 1 if np.isfinite(disp[10, 10]) else 1.0
    write_pfm(path, disp)
    report = golden_check(root, render=False)
    assert report.failures == ("boxes/expected/sgbm-w9.pfm: disparity differs at 1 pixels",)


def test_missing_output_and_missing_manifest_fail(tmp_path):
    root = _one_scene_copy(tmp_path)
    (root / "boxes" / "expected" / "awct-w21.pfm").unlink()
    report = golden_check(root, render=False)
    assert len(report.failures) == 1 and report.failures[0].startswith(
        "boxes/expected/awct-w21.pfm: unreadable")
    assert not golden_check(tmp_path / "nowhere", render=False).ok


# --------------------------------------------------------------------------- render tolerances
def _pair(disp: np.ndarray, mask: np.ndarray, image: np.ndarray) -> SimpleNamespace:
    return SimpleNamespace(left=image, right=image, disp_left=disp, disp_right=disp,
                           mask_left=mask)


def _scene() -> SimpleNamespace:
    disp = np.full((40, 40), 5.0, np.float32)
    disp[:, 20:] = 9.0  # one depth edge between columns 19 and 20
    mask = np.full((40, 40), 255, np.uint8)
    mask[:, 20:24] = 128
    image = np.random.default_rng(0).integers(0, 256, (40, 40, 3), dtype=np.uint8)
    return _pair(disp, mask, image)


def test_render_tolerances_accept_boundary_flips_and_small_noise():
    stored = _scene()
    disp = stored.disp_left.copy()
    disp[7, 20] = 5.0  # the rasteriser picked the other surface at the edge
    disp[3, 3] += 5e-4  # below 1e-3 px
    mask = stored.mask_left.copy()
    mask[7, 23] = 255  # an occlusion boundary pixel flipped
    image = stored.left.copy()
    image[0, :4, 0] ^= 1  # tiny intensity change
    failures: list[str] = []
    diff = compare_render("s", _pair(disp, mask, image), stored, failures)
    assert failures == []
    assert diff.mask_changed == 1 and diff.boundary_pixels == 1
    assert diff.disparity_max_abs == pytest.approx(5e-4, abs=1e-6)


def test_render_tolerances_reject_interior_changes():
    stored = _scene()
    disp = stored.disp_left.copy()
    disp[30, 5] += 2e-3  # interior, beyond 1e-3 px
    mask = stored.mask_left.copy()
    mask[30, 5] = 128  # interior mask flip
    image = stored.left.copy()
    image[:, :, 0] = 255 - image[:, :, 0]  # a different texture
    failures: list[str] = []
    compare_render("s", _pair(disp, mask, image), stored, failures)
    names = sorted(f.split(":")[0] for f in failures)
    assert names == ["s/disp0.pfm", "s/disp1.pfm", "s/im0.png", "s/im1.png", "s/mask0nocc.png"]


def test_render_tolerances_reject_too_many_boundary_flips():
    stored = _scene()
    mask = stored.mask_left.copy()
    mask[:, 23] = 255  # 40 flips on the boundary > 0.5 % of 1600 pixels
    assert 40 > TOLERANCES["boundary_fraction"] * 1600
    failures: list[str] = []
    compare_render("s", _pair(stored.disp_left, mask, stored.left), stored, failures)
    assert [f.split(":")[0] for f in failures] == ["s/mask0nocc.png"]


# --------------------------------------------------------------------------- GL
@pytest.mark.gl
def test_fresh_render_matches_stored_golden(renderer):
    report = golden_check(GOLDEN, matchers=False)
    assert report.failures == (), report.summary()
    assert [r.scene for r in report.render] == [s for s, _ in GOLDEN_SCENES]


@pytest.mark.gl
def test_the_check_names_the_references_renderer_and_its_own(renderer, tmp_path):
    root = _one_scene_copy(tmp_path, "fronto_plane")
    manifest = json.loads((root / "manifest.json").read_text())
    manifest["gl"] = {"backend": renderer.backend, "GL_RENDERER": renderer.gl_renderer,
                      "GL_VERSION": renderer.gl_version}
    (root / "manifest.json").write_text(json.dumps(manifest))
    same = golden_check(root, matchers=False)
    assert same.ok and same.same_renderer
    assert same.renderer_gl == manifest["gl"]
    assert f"renderer: references by {renderer.gl_renderer}" in same.summary()
    assert "rendered here by the same" in same.summary()
    # references from another driver, and one image that differs: the failure names both
    manifest["gl"] = {"backend": "egl", "GL_RENDERER": "NVIDIA H200/PCIe/SSE2",
                      "GL_VERSION": "4.6.0 NVIDIA 570.86.15"}
    (root / "manifest.json").write_text(json.dumps(manifest))
    im0 = root / "fronto_plane" / "im0.png"
    img = read_image(im0)
    im0.write_bytes(encode_png(np.ascontiguousarray(255 - img)))
    other = golden_check(root, matchers=False)
    assert not other.same_renderer
    assert len(other.failures) == 1 and other.failures[0].startswith("fronto_plane/im0.png")
    assert f"rendered by {renderer.gl_renderer}" in other.failures[0]
    assert "references by NVIDIA H200/PCIe/SSE2, 4.6.0 NVIDIA 570.86.15 (egl)" in \
        other.failures[0]
    assert f"rendered here by {renderer.gl_renderer}" in other.summary()


@pytest.mark.gl
@pytest.mark.slow
def test_update_is_deterministic_and_reports_changes(renderer, tmp_path):
    root = tmp_path / "g"
    first = golden_update(root)
    assert {c.status for c in first} == {"added"}
    before = {p.relative_to(root): p.read_bytes() for p in root.rglob("*") if p.is_file()}
    assert golden_update(root) == []  # same bytes twice
    assert golden_check(root).ok
    # tamper, then update restores the files and says what changed
    metrics = root / "boxes" / "expected" / "metrics.json"
    data = json.loads(metrics.read_text())
    data["ct-w5"]["all"]["pobmp"] = 99.0
    metrics.write_text(json.dumps(data))
    (root / "flying" / "stale.txt").write_text("not managed")  # never touched by update
    changes = golden_update(root)
    assert [(c.path, c.status) for c in changes] == [("boxes/expected/metrics.json", "modified")]
    assert "ct-w5.all.pobmp: stored 99.0" in changes[0].detail
    assert "modified  boxes/expected/metrics.json" in format_changes(changes)
    after = {p.relative_to(root): p.read_bytes() for p in root.rglob("*") if p.is_file()}
    assert after.pop(Path("flying/stale.txt")) == b"not managed"
    assert after == before
