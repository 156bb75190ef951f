"""Golden references: stored rendered pairs and every matcher's exact output on them.

``golden/`` (at the repository root) holds a few small rendered pairs in the Middlebury 2014
layout and, for each, the disparity (PFM) and metrics (JSON) that every matcher method gives on
the *stored* images. :func:`golden_check` verifies two things separately:

1. **Matchers, exactly.** Each method is run on the stored ``im0.png``/``im1.png``; its
   disparity must equal the stored PFM bit for bit (``inf`` at the same pixels) and its
   metrics (computed against the stored ``disp0GT.pfm`` and ``mask0nocc.png``) must equal the
   stored JSON exactly. Rendering cannot affect this part.
2. **Rendering, within tolerances** that survive Mesa versions (a fresh render of each scene
   against the stored one, see :data:`TOLERANCES`):

   - ground-truth disparity (``disp0``, ``disp1``): ``|Δd| <= 1e-3`` px where both are
     finite; a pixel beyond that is allowed only within 1 px of a boundary (a mask-code change
     or a jump of more than 1 px between 4-neighbours of the stored map), where a rasteriser may
     pick the other surface;
   - occlusion mask: identical except within 1 px of a boundary;
   - the boundary exceptions of each map together: at most 0.5 % of the pixels;
   - images: mean ``|ΔI| <= 1`` grey level and 99th percentile ``<= 10`` grey levels, per
     image over all pixels and channels (multisample resolve and mipmap filtering may differ
     between Mesa versions; the percentile bounds the edges, the mean the rest).

   The report names the GL renderer the references come from (the manifest's ``gl``) and the
   one it rendered with; when they differ, each render failure names both, so a difference is
   always reported for a pair of renderers (llvmpipe's references checked on another driver
   measure that driver's freedoms, not a regression).

:func:`golden_update` regenerates everything (deterministically: the same versions give the
same bytes) and reports what changed. Layout::

    golden/manifest.json              versions, GL strings, rig, seeds, cases, tolerances, sha256
    golden/README.md                  this layout and the commands
    golden/<scene>/im0.png ... calib.txt, scene.json      (synth.write.export.write_pair)
    golden/<scene>/expected/<method>-w<window>.pfm        matcher output, float32
    golden/<scene>/expected/metrics.json                  metrics + operation counts per case

One module on purpose: generation, check and update of one folder share its layout and manifest
(the render tolerances are in :mod:`synth.jobs.golden_compare`).
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import math
import platform
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from matcher import match
from matcher.io import atomic_write_bytes, decode_pfm, encode_pfm, read_pfm
from matcher.metrics import evaluate
from stereoforge.errors import FormatError, StereoforgeError
from synth.formats import read_sample
from synth._util.json_records import loads_json_object, read_json_object
from synth.jobs.golden_compare import (
    TOLERANCES,
    RenderDiff,
    compare_render,
    disparity_stats,
    image_stats,
    records_differ,
)
from synth.camera.rig import StereoRig

__all__ = [
    "GOLDEN_SCENES", "GOLDEN_CASES", "GOLDEN_RIG", "MAX_DISPARITY", "DELTA", "TOLERANCES",
    "RenderDiff", "CheckReport", "GoldenChange", "golden_check", "golden_update",
    "format_changes", "generate_golden",
]

#: ``(preset, seed)`` of every golden scene (folder name = preset name).
GOLDEN_SCENES: tuple[tuple[str, int], ...] = (
    ("fronto_plane", 1), ("slanted_plane", 2), ("boxes", 3), ("flying", 4))
#: ``(method, window)`` of every stored matcher output.
GOLDEN_CASES: tuple[tuple[str, int], ...] = tuple(
    (m, w) for m in ("ct", "sct", "cthw", "awct", "awsct") for w in (5, 21)
) + (("bm", 9), ("sgbm", 9))
#: Rig of every golden pair (presets keep their framing: ``fx = 600 * width / 640``).
GOLDEN_RIG = StereoRig.default(160, 120, baseline=0.2)
MAX_DISPARITY = 24
DELTA = 3.0
_FORMAT = 1
_SCENE_FILES = ("im0.png", "im1.png", "disp0GT.pfm", "disp1GT.pfm", "mask0nocc.png", "calib.txt",
                "scene.json")
_VERSION_DISTS = ("stereoforge", "numpy", "opencv-python-headless", "numba", "scikit-image",
                  "scipy", "trimesh", "PyOpenGL")

_REGENERATE = "regenerate it with `stereoforge golden update`"


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class CheckReport:
    """Result of :func:`golden_check`.

    Attributes
    ----------
    root : Path
    failures : tuple of str
        One line per failure, starting with the file (relative to ``root``) it concerns.
    notes : tuple of str
        Differences that are not failures (e.g. versions other than the manifest's).
    matcher_cases : int
        ``(scene, method, window)`` outputs compared exactly.
    render : tuple of RenderDiff
        One per re-rendered scene (empty with ``render=False``).
    reference_gl : dict
        The GL strings (``backend``, ``GL_RENDERER``, ``GL_VERSION``) the stored pairs were
        rendered with (the manifest's ``gl``; empty if it has none).
    renderer_gl : dict
        Those of this check's renders (empty with ``render=False``).
    """

    root: Path
    failures: tuple[str, ...]
    notes: tuple[str, ...]
    matcher_cases: int
    render: tuple[RenderDiff, ...]
    reference_gl: dict = field(default_factory=dict)
    renderer_gl: dict = field(default_factory=dict)

    @property
    def same_renderer(self) -> bool:
        """True when this check rendered with the references' GL renderer and version."""
        return all(self.reference_gl.get(k) == self.renderer_gl.get(k)
                   for k in ("GL_RENDERER", "GL_VERSION"))

    @property
    def ok(self) -> bool:
        """True when nothing failed."""
        return not self.failures

    def summary(self) -> str:
        """Human-readable report (one line per failure, note and scene)."""
        lines = [f"golden {self.root}: {'OK' if self.ok else 'FAILED'} "
                 f"({self.matcher_cases} matcher outputs, {len(self.render)} scenes re-rendered)"]
        lines += [f"  FAIL {f}" for f in self.failures]
        lines += [f"  note {n}" for n in self.notes]
        if self.render:
            lines.append(f"  renderer: references by {_gl_name(self.reference_gl)}; rendered here "
                         f"by {'the same' if self.same_renderer else _gl_name(self.renderer_gl)}")
        lines += [f"  render {r.scene}: mean|dI| {r.image_mean_abs:.3f}, p99 {r.image_p99_abs:.1f}"
                  f", max {r.image_max_abs:.0f}; max|dd| {r.disparity_max_abs:.2e} px; "
                  f"boundary px {r.boundary_pixels}; mask changed {r.mask_changed}"
                  for r in self.render]
        return "\n".join(lines)


@dataclass(frozen=True)
class GoldenChange:
    """One file changed by :func:`golden_update`.

    Attributes
    ----------
    path : str
        Relative to the golden root.
    status : {"added", "modified", "removed"}
    detail : str
        What changed (max differences, metric deltas), empty for added/removed files.
    """

    path: str
    status: str
    detail: str


# --------------------------------------------------------------------------- helpers
def _json_bytes(obj: Any) -> bytes:
    return (json.dumps(obj, indent=2, sort_keys=True, allow_nan=False) + "\n").encode()


def _gl_name(gl: dict) -> str:
    """``GL_RENDERER, GL_VERSION (backend)`` of a manifest's or a renderer's GL strings."""
    if not gl:
        return "an unrecorded renderer"
    return (f"{gl.get('GL_RENDERER', '?')}, {gl.get('GL_VERSION', '?')} "
            f"({gl.get('backend', '?')})")


def _finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _case_name(method: str, window: int) -> str:
    return f"{method}-w{window}"


def _case_record(result: Any, gt: np.ndarray, mask: np.ndarray) -> dict:
    """Metrics (all pixels with GT, and non-occluded) and operation counts of one output."""
    rec: dict[str, Any] = {}
    for region in ("all", "nonocc"):
        m = evaluate(result.disparity, gt, delta=DELTA, region=region, occlusion_mask=mask)
        rec[region] = {k: (_finite_or_none(v) if isinstance(v, float) else v)
                       for k, v in vars(m).items()}
    ops = result.ops
    rec["ops"] = None if ops is None else {"census_comparisons": int(ops.census_comparisons),
                                           "hamming_words": int(ops.hamming_words)}
    ratio = getattr(result, "reduction_ratio", None)
    rec["reduction_ratio"] = None if ratio is None else float(ratio)
    return rec


def _run_cases(scene_dir: Path) -> dict[str, tuple[np.ndarray, dict]]:
    """Every golden case on the stored pair in ``scene_dir``: name -> (disparity, record)."""
    s = read_sample(scene_dir)
    out = {}
    for method, window in GOLDEN_CASES:
        res = match(s.left, s.right, method=method, window=window, max_disparity=MAX_DISPARITY)
        out[_case_name(method, window)] = (res.disparity,
                                           _case_record(res, s.disp_left, s.mask_left))
    return out


def _versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for dist in _VERSION_DISTS:
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:  # pragma: no cover
            out[dist] = "unknown"
    return out


def _readme() -> bytes:
    cases = ", ".join(_case_name(m, w) for m, w in GOLDEN_CASES)
    scenes = ", ".join(f"{p} (seed {s})" for p, s in GOLDEN_SCENES)
    return (
        "# Golden references (generated by `synth.jobs.golden.golden_update`; do not edit)\n\n"
        f"Scenes ({GOLDEN_RIG.width} x {GOLDEN_RIG.height}, fx = {GOLDEN_RIG.fx:g} px, "
        f"baseline = {GOLDEN_RIG.baseline:g} m): {scenes}.\n"
        f"Matcher cases (max_disparity = {MAX_DISPARITY}, delta = {DELTA:g}): {cases}.\n\n"
        "- `<scene>/` MiddEval3 layout (`im0.png`, `im1.png`, `disp0GT.pfm`, `disp1GT.pfm`, "
        "`mask0nocc.png`, `calib.txt`) and `scene.json`\n"
        "- `<scene>/expected/<method>-w<window>.pfm` each method's disparity on the stored "
        "images; `expected/metrics.json` its metrics (`all`, `nonocc`) and operation counts\n"
        "- `manifest.json` seeds, rig, versions, GL renderer, tolerances, sha256 of every file\n\n"
        "Check: `stereoforge golden check` (or `synth.jobs.golden.golden_check()`); regenerate: "
        "`stereoforge golden update` (or `synth.jobs.golden.golden_update()`). See "
        "`src/synth/jobs/golden.py` for the tolerances of the render check.\n"
    ).encode()


# --------------------------------------------------------------------------- generation
def generate_golden(*, backend: str = "auto") -> dict[str, bytes]:
    """Render the golden scenes and run every case; return ``relative path -> bytes``.

    Deterministic: the same package versions and GL renderer give the same bytes.
    """
    from scenes import get_preset
    from synth.write.export import write_pair
    from synth.pair import render_pair
    from synth.render.renderer import Renderer

    files: dict[str, bytes] = {}
    scenes_meta = []
    gl: dict[str, str] = {}
    with tempfile.TemporaryDirectory(prefix="golden-") as tmp, \
            Renderer(GOLDEN_RIG.width, GOLDEN_RIG.height, backend=backend) as renderer:
        gl = {"backend": renderer.backend, "GL_RENDERER": renderer.gl_renderer,
              "GL_VERSION": renderer.gl_version}
        for preset, seed in GOLDEN_SCENES:
            spec = get_preset(preset, seed=seed)
            pair = render_pair(spec, GOLDEN_RIG, renderer=renderer)
            scene_dir = Path(tmp, preset)
            scene_dir.mkdir()
            write_pair(pair, scene_dir, scene=spec, seed=seed, preview=False, fsync=False)
            for name in _SCENE_FILES:
                files[f"{preset}/{name}"] = (scene_dir / name).read_bytes()
            records = {}
            for case, (disp, rec) in _run_cases(scene_dir).items():
                files[f"{preset}/expected/{case}.pfm"] = encode_pfm(disp)
                records[case] = rec
            files[f"{preset}/expected/metrics.json"] = _json_bytes(records)
            scenes_meta.append({"name": preset, "preset": preset, "seed": seed})
    files["README.md"] = _readme()
    manifest = {
        "format": _FORMAT,
        "versions": _versions(),
        "gl": gl,
        "rig": GOLDEN_RIG.to_dict(),
        "max_disparity": MAX_DISPARITY,
        "delta": DELTA,
        "scenes": scenes_meta,
        "cases": [{"method": m, "window": w} for m, w in GOLDEN_CASES],
        "tolerances": TOLERANCES,
        "sha256": {p: hashlib.sha256(b).hexdigest() for p, b in sorted(files.items())},
    }
    files["manifest.json"] = _json_bytes(manifest)
    return dict(sorted(files.items()))


# --------------------------------------------------------------------------- check
def _check_matchers(root: Path, manifest: dict, failures: list[str]) -> int:
    n = 0
    for scene in manifest["scenes"]:
        name = scene["name"]
        try:
            stored_metrics = json.loads((root / name / "expected" / "metrics.json").read_text())
        except (OSError, ValueError) as exc:
            failures.append(f"{name}/expected/metrics.json: unreadable ({exc})")
            stored_metrics = {}
        try:
            results = _run_cases(root / name)
        except (OSError, ValueError) as exc:
            failures.append(f"{name}/: cannot load the stored pair ({exc})")
            continue
        for case, (disp, rec) in results.items():
            n += 1
            pfm = f"{name}/expected/{case}.pfm"
            try:
                old = read_pfm(root / pfm)
            except (OSError, ValueError) as exc:
                failures.append(f"{pfm}: unreadable ({exc})")
            else:
                if old.shape != disp.shape or not np.array_equal(old, disp, equal_nan=True):
                    diff = (old != disp).sum() if old.shape == disp.shape else "all"
                    failures.append(f"{pfm}: disparity differs at {diff} pixels")
            if case not in stored_metrics:
                failures.append(f"{name}/expected/metrics.json: case {case} missing")
                continue
            for d in records_differ(rec, stored_metrics[case]):
                failures.append(f"{name}/expected/metrics.json: {case}.{d}")
    return n


def _check_render(root: Path, manifest: dict, backend: str, failures: list[str]
                  ) -> tuple[list[RenderDiff], dict]:
    """Each scene rendered afresh against its stored pair, and the GL strings of the renderer.

    A renderer other than the references' (another driver or Mesa version: the GL
    specification leaves rasterisation, multisample resolve and mipmap generation partly to the
    implementation) is named in each render failure, so a report says between which two
    renderers a difference was measured."""
    from scenes import get_preset
    from synth.pair import render_pair
    from synth.render.renderer import Renderer

    rig = StereoRig.from_dict(manifest["rig"])
    out = []
    mine: list[str] = []
    with Renderer(rig.width, rig.height, backend=backend) as renderer:
        gl = {"backend": renderer.backend, "GL_RENDERER": renderer.gl_renderer,
              "GL_VERSION": renderer.gl_version}
        for scene in manifest["scenes"]:
            stored = read_sample(root, scene["name"])
            fresh = render_pair(get_preset(scene["preset"], seed=scene["seed"]), rig,
                                renderer=renderer)
            out.append(compare_render(scene["name"], fresh, stored, mine))
    reference = manifest.get("gl") if isinstance(manifest.get("gl"), dict) else {}
    if any(reference.get(k) != gl[k] for k in ("GL_RENDERER", "GL_VERSION")):
        mine = [f"{f} [rendered by {_gl_name(gl)}; references by {_gl_name(reference)}]"
                for f in mine]
    failures += mine
    return out, gl


def golden_check(root: str | Path = "golden", *, backend: str = "auto", matchers: bool = True,
                 render: bool = True) -> CheckReport:
    """Check the golden references in ``root`` (see the module docstring).

    Parameters
    ----------
    root : str or Path
        Golden folder (holding ``manifest.json``).
    backend : {"auto", "egl", "osmesa"}
        GL backend of the render check.
    matchers : bool
        Run the exact matcher check (no GL needed).
    render : bool
        Run the render check (needs GL).

    Returns
    -------
    CheckReport
        ``report.ok`` is False when anything failed; ``report.failures`` name the files.

    Examples
    --------
    >>> golden_check("/nonexistent").failures
    ('manifest.json: missing in /nonexistent; create it with golden_update(root)',)
    """
    root = Path(root)
    failures: list[str] = []
    notes: list[str] = []
    try:
        manifest = read_json_object(root / "manifest.json", what="golden manifest",
                                    keys={"scenes": list, "rig": dict, "versions": dict},
                                    fix=_REGENERATE, error=FormatError)
        for i, scene in enumerate(manifest["scenes"]):
            loads_json_object(json.dumps(scene), where=f"{root / 'manifest.json'} scenes[{i}]",
                              what="golden scene entry", fix=_REGENERATE, error=FormatError,
                              keys={"name": str, "preset": str, "seed": int})
    except FileNotFoundError:
        return CheckReport(root, (f"manifest.json: missing in {root}; create it with "
                                  "golden_update(root)",), (), 0, ())
    for dist, version in _versions().items():
        stored = manifest.get("versions", {}).get(dist)
        if stored != version:
            notes.append(f"{dist} {version} (manifest: {stored})")
    n = _check_matchers(root, manifest, failures) if matchers else 0
    diffs, gl = _check_render(root, manifest, backend, failures) if render else ([], {})
    reference = manifest.get("gl") if isinstance(manifest.get("gl"), dict) else {}
    return CheckReport(root, tuple(failures), tuple(notes), n, tuple(diffs), dict(reference), gl)


# --------------------------------------------------------------------------- update
def _describe(path: str, new: bytes, old: bytes) -> str:
    import cv2

    if path.endswith(".pfm"):
        x, y = decode_pfm(new, where=f"new {path}"), decode_pfm(old, where=f"stored {path}")
        if x.shape != y.shape:
            return f"shape {y.shape} -> {x.shape}"
        max_abs, n_bad, n_fin = disparity_stats(x, y)
        return (f"max |dd| {max_abs:.3g} px, {int((x != y).sum())} pixels changed, "
                f"{n_fin} finite/inf flips")
    if path.endswith(".png"):
        x = cv2.imdecode(np.frombuffer(new, np.uint8), cv2.IMREAD_UNCHANGED)
        y = cv2.imdecode(np.frombuffer(old, np.uint8), cv2.IMREAD_UNCHANGED)
        if x is None or y is None or x.shape != y.shape:
            return "image shape or encoding changed"
        mean, p99, mx = image_stats(x, y)
        return f"mean |dI| {mean:.3f}, p99 {p99:.1f}, max {mx:.0f}, {int((x != y).sum())} values changed"
    if path.endswith(".json"):
        try:
            diffs = records_differ(json.loads(new), json.loads(old))
        except ValueError:
            return "content changed"
        if path.endswith("metrics.json"):
            diffs = [d for d in diffs if ".pobmp" in d or ".rms" in d or "ops" in d] or diffs
        diffs = [d if len(d) <= 160 else d[:157] + "..." for d in diffs]
        shown = "; ".join(diffs[:12])
        return shown + (f"; ... ({len(diffs)} differences)" if len(diffs) > 12 else "")
    return "content changed"


def golden_update(root: str | Path = "golden", *, backend: str = "auto") -> list[GoldenChange]:
    """Regenerate the golden references in ``root``; return what changed.

    Every file is written atomically; files listed in the old manifest that the new one no
    longer has are removed (nothing else in ``root`` is touched).

    Parameters
    ----------
    root : str or Path
        Golden folder (created if missing).
    backend : {"auto", "egl", "osmesa"}

    Returns
    -------
    list of GoldenChange
        Added, modified and removed files, sorted by path (empty when nothing changed).
    """
    root = Path(root)
    files = generate_golden(backend=backend)
    try:
        old = read_json_object(root / "manifest.json", what="golden manifest")
        old_listed = set(old.get("sha256", {})) if isinstance(old.get("sha256"), dict) else set()
        old_listed.add("manifest.json")
    except (OSError, StereoforgeError):  # absent or damaged: everything counts as added
        old_listed = set()
    changes = []
    for rel, data in files.items():
        path = root / rel
        old = path.read_bytes() if path.is_file() else None
        if old == data:
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, data)
        changes.append(GoldenChange(rel, "added" if old is None else "modified",
                                    "" if old is None else _describe(rel, data, old)))
    for rel in sorted(old_listed - set(files)):
        if (root / rel).is_file():
            (root / rel).unlink()
            changes.append(GoldenChange(rel, "removed", ""))
    return sorted(changes, key=lambda c: c.path)


def format_changes(changes: list[GoldenChange]) -> str:
    """One line per change (``"no changes"`` when empty).

    Examples
    --------
    >>> print(format_changes([GoldenChange("a/im0.png", "modified", "mean |dI| 0.1")]))
    modified  a/im0.png: mean |dI| 0.1
    """
    if not changes:
        return "no changes"
    return "\n".join(f"{c.status:<9} {c.path}" + (f": {c.detail}" if c.detail else "")
                     for c in changes)
