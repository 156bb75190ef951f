#!/usr/bin/env python3
"""Mutation check: plant deliberate bugs in matcher, synth and scenes; show which tests kill each.

Each mutant is one textual change to one source file. For every mutant the script copies ``src/``,
``tests/``, ``conftest.py`` and ``pyproject.toml`` into a temporary folder, applies the change,
runs the mutant's tests there (the copy's ``src`` first on ``PYTHONPATH``; the matcher tests for
matcher mutants, a relevant subset of the synth/scenes tests for the others, GL required) and
records the tests that fail. A mutant survives when no test fails: that is a hole in the suite.
Before the mutants, each distinct test set runs once on the unmutated copy and must pass (else a
failing test would "kill" every mutant). The script exits 1 if any mutant survives (or cannot be
planted because its target text moved), so it can guard the suite itself.

Usage::

    .venv/bin/python tools/mutants.py                       # all mutants, Markdown table on stdout
    .venv/bin/python tools/mutants.py --list                # what would be planted
    .venv/bin/python tools/mutants.py -k spiral             # mutants whose name contains "spiral"
    .venv/bin/python tools/mutants.py --under src/synth --under src/scenes   # synth and scenes
    .venv/bin/python tools/mutants.py -k learned: -k train: -k validate:   # the six of those

It is slow (each mutant recompiles the numba kernels it uses; the synth mutants render): about
a minute per mutant on 2 cores, 51 minutes for the 43 of the matcher, synth and scenes (every
one killed); 18 minutes for the six of the learned matcher, training and validate's gate
(``-k learned: -k train: -k validate:``, every one killed). It does not run in CI.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutant:
    name: str
    path: str  # relative to the repository root
    edits: tuple[tuple[str, str], ...]  # (exact old text, new text); each old text must occur
    why: str
    tests: tuple[str, ...] = ()  # pytest arguments (paths, -m ...); default: the matcher tests


_U8_BITS = tuple((f"if c > s{k}[x]", f"if c < s{k}[x]") for k in range(8))
_U8_BITS_GE = tuple((f"if c > s{k}[x]", f"if c >= s{k}[x]") for k in range(8))

MUTANTS = (
    Mutant(
        "census comparison flipped",
        "src/matcher/_kernels/census.py",
        (*_U8_BITS, ("centre[x] > src[x]", "centre[x] < src[x]")),
        "bit = I(p) < I(p') instead of the paper's I(p) > I(p') (Eq. 2)",
    ),
    Mutant(
        "census comparison not strict",
        "src/matcher/_kernels/census.py",
        (*_U8_BITS_GE, ("centre[x] > src[x]", "centre[x] >= src[x]")),
        "ties I(p) == I(p') set the bit",
    ),
    Mutant(
        "spiral order broken (rings start downwards)",
        "src/matcher/patterns.py",
        (("out += [(-k, r) for k in range(0, r + 1)]", "out += [(k, r) for k in range(0, r + 1)]"),),
        "each ring runs clockwise from its start instead of counter-clockwise (Fig. 5)",
    ),
    Mutant(
        "disparity off by one",
        "src/matcher/_kernels/census.py",
        (("val = np.float64(d)", "val = np.float64(d + 1)"),),
        "the winner-takes-all result of CT/SCT is d + 1",
    ),
    Mutant(
        "ties go to the largest d",
        "src/matcher/_kernels/census.py",
        (("if c[i] < bc[i]:", "if c[i] <= bc[i]:"),),
        "winner-takes-all keeps the last minimum instead of the first",
    ),
    Mutant(
        "invalid pixels counted as good",
        "src/matcher/metrics.py",
        (("return 100.0 * (int((err > threshold).sum()) + (n - err.size)) / n",
          "return 100.0 * int((err > threshold).sum()) / n"),),
        "PoBMP and bad-x forget the invalid estimates",
    ),
    Mutant(
        "N miscounted (one decrease too few)",
        "src/matcher/_kernels/adaptive.py",
        (("(rn == n_decreases) & (ch == largest)", "(rn == n_decreases - 1) & (ch == largest)"),),
        "AWCT stops after N - 1 consecutive decreases of the edge proportion",
    ),
    Mutant(
        "AWCT ignores the smaller window",
        "src/matcher/_kernels/adaptive.py",
        (("    if lowest >= total_bits:\n        _row_cost(", "    if lowest >= 0:\n        _row_cost("),
         ("            if b < total_bits:\n                out[x] = np.float32(_rescore(",
          "            if b < 0:\n                out[x] = np.float32(_rescore(")),
        "pixels with a small window are scored over the largest window's code, not their prefix",
    ),
)


_PINNED = ("tests/synth/test_pinned.py", "tests/synth/test_golden_samples.py")
_NOT_SLOW = ("-m", "not slow")
_DATASET = ("tests/synth/test_dataset.py", *_PINNED, *_NOT_SLOW)
_PHOTOMETRIC = ("tests/synth/test_photometric.py", "tests/synth/test_photometric_properties.py",
                *_PINNED)
_SAMPLING = ("tests/synth/test_dataset_sampling.py", *_PINNED)
_CALIB = ("tests/synth/test_rig.py", "tests/synth/test_render.py", *_PINNED, *_NOT_SLOW)
_SCENES = ("tests/scenes", *_PINNED)

MUTANTS += (
    Mutant(
        "resume trusts a sample folder",
        "src/synth/dataset/run.py",
        (("if sample_problems(out, fmt, i)]", "if not sample_dir(out, fmt, i).is_dir()]"),),
        "an emptied or truncated sample counts as done (the bug before completion records)",
        _DATASET,
    ),
    Mutant(
        "resume ignores the recorded sizes",
        "src/synth/dataset/storage/integrity.py",
        (('if size != entry["bytes"]:', 'if size != entry.get("size", size):'),),
        "the size check reads a key the record does not have: a truncated file passes",
        _DATASET,
    ),
    Mutant(
        "record forgets the KITTI images",
        "src/synth/dataset/storage/commit.py",
        (('for path in sorted(p for p in tmp.rglob("*") if p.is_file())]',
          'for path in sorted(p for p in tmp.glob("*") if p.is_file())]'),),
        "the completion record lists the sample folder only, not training/image_2/ ... of KITTI",
        _DATASET,
    ),
    Mutant(
        "verify stops at the last sample present",
        "src/synth/dataset/storage/integrity.py",
        (("for index in sorted(set(range(last + 1)) | set(present)):",
          "for index in sorted(set(present)):"),),
        "holes (missing indices) are not reported",
        _DATASET,
    ),
    Mutant(
        "photometric noise seeded by the dataset",
        "src/synth/dataset/sample.py",
        (("rng=stream(draw.seed, STREAM_PHOTOMETRIC)",
          "rng=stream(config.seed, STREAM_PHOTOMETRIC)"),),
        "every sample gets the same noise field (dataset seed instead of the sample's)",
        _DATASET,
    ),
    Mutant(
        "photometric noise shares the preset's stream",
        "src/synth/dataset/sample.py",
        (("rng=stream(draw.seed, STREAM_PHOTOMETRIC)", "rng=stream(draw.seed, 1)"),),
        "the noise is drawn from the stream that seeds the base preset (correlated draws)",
        _DATASET,
    ),
    Mutant(
        "occluder texture ignores depth",
        "src/synth/dataset/config/sampling.py",
        (("frequency=f_px * rig.fx / z,", "frequency=f_px * rig.fx,"),),
        "occluder textures get f_px * fx cycles/m at any depth instead of f_px * fx / Z",
        _SAMPLING,
    ),
    Mutant(
        "occluders placed upside down",
        "src/synth/dataset/config/sampling.py",
        (("(v - rig.cy) * z / rig.fy", "(rig.cy - v) * z / rig.fy"),),
        "the drawn pixel row is mirrored (OpenCV's y axis points down)",
        _SAMPLING,
    ),
    Mutant(
        "calib vmax floored",
        "src/synth/formats/middlebury.py",
        (("vmax = int(math.ceil(hi))", "vmax = int(math.floor(hi))"),),
        "calib.txt vmax below the largest disparity",
        _CALIB,
    ),
    Mutant(
        "calib ndisp without the + 1",
        "src/synth/formats/middlebury.py",
        (("ndisp = int(16 * math.ceil((vmax + 1) / 16))", "ndisp = int(16 * math.ceil(vmax / 16))"),),
        "ndisp = vmax when vmax is a multiple of 16 (the search misses d = vmax)",
        _CALIB,
    ),
    Mutant(
        "calib baseline in metres",
        "src/synth/camera/rig.py",
        (('"baseline": self.baseline * 1000.0,', '"baseline": self.baseline,'),),
        "calib.txt baseline in metres instead of Middlebury's millimetres",
        _CALIB,
    ),
    Mutant(
        "occluded fraction counts invalid pixels",
        "src/synth/dataset/sample.py",
        (("occluded = np.count_nonzero(pair.mask_left == 128)",
          "occluded = np.count_nonzero(pair.mask_left != 255)"),),
        "manifest occluded_fraction includes the invalid (mask 0) pixels",
        _DATASET,
    ),
    Mutant(
        "texture frequency statistic at the wrong depth",
        "src/synth/dataset/config/sampling.py",
        (("values = [o.texture.frequency * o.pose.translation[2] / fx",
          "values = [o.texture.frequency / fx"),),
        "manifest texture_frequency_px forgets the object's depth",
        _SAMPLING,
    ),
    Mutant(
        "manifest CSV booleans in Python spelling",
        "src/synth/dataset/storage/manifest.py",
        (('return "true" if value else "false"', "return str(value)"),),
        "manifest.csv writes True/False instead of true/false",
        _DATASET,
    ),
    Mutant(
        "blur border replicated",
        "src/synth/appearance/photometric.py",
        (("borderType=cv2.BORDER_REFLECT_101", "borderType=cv2.BORDER_REPLICATE"),),
        "the documented reflected border becomes a replicated one",
        _PHOTOMETRIC,
    ),
    Mutant(
        "gain applied after the bias",
        "src/synth/appearance/photometric.py",
        (("    v = np.rint(fma(x, gain, noise + bias))",
          "    v = np.rint(fma(x, gain, noise + bias * gain))"),),
        "with noise, the right image is (x + bias) * gain instead of x * gain + bias",
        _PHOTOMETRIC,
    ),
    Mutant(
        "gamma inverted on blurred images",
        "src/synth/appearance/photometric.py",
        (("lut = _gamma_table16(params.gamma)",
          "lut = _gamma_table16(1.0 / params.gamma)"),),
        "255 * (x / 255) ** (1 / gamma)",
        _PHOTOMETRIC,
    ),
    Mutant(
        "texture contrast doubled",
        "src/scenes/textures.py",
        (("grey *= np.float32(spec.contrast * 0.5)", "grey *= np.float32(spec.contrast)"),),
        "g = mean + contrast * p instead of mean + contrast * p / 2",
        _SCENES,
    ),
    Mutant(
        "scene round trip drops the pose",
        "src/scenes/serialize.py",
        (('kw["pose"] = _build(Pose, _take(kw.get("pose", {}), Pose, f"{where}.pose"), f"{where}.pose")',
          'kw["pose"] = _build(Pose, {}, f"{where}.pose")'),),
        "scene_from_dict rebuilds every object at the default pose",
        _SCENES,
    ),
    Mutant(
        "sample seed ignores the index",
        "src/synth/dataset/config/sampling.py",
        (("spawn_key=(int(index),)", "spawn_key=(0,)"),),
        "every sample of a dataset draws the same scene and sensor (one seed for all)",
        _SAMPLING,
    ),
    Mutant(
        "JPEG round trip of the left image only",
        "src/synth/appearance/photometric.py",
        (("out = [_jpeg(img, params.jpeg_quality) for img in out]",
          "out = [_jpeg(out[0], params.jpeg_quality), out[1]]"),),
        "the right image skips the JPEG round trip (the two views see different sensors)",
        _PHOTOMETRIC,
    ),
    Mutant(
        "disparity from fy",
        "src/synth/camera/rig.py",
        (("d = np.divide(self.fx * self.baseline, z,", "d = np.divide(self.fy * self.baseline, z,"),),
        "d = fy * B / Z: wrong for every rig with non-square pixels",
        _CALIB,
    ),
    Mutant(
        "stripes ignore their angle",
        "src/scenes/textures.py",
        (("along = math.cos(theta) * u[None, :] + math.sin(theta) * v[:, None]",
          "along = u[None, :] + 0.0 * v[:, None]"),),
        "stripes are vertical at any angle (checkers too, along one axis)",
        _SCENES,
    ),
)


# planted bugs the suite let through until each got its pin (the scores, the OpenCV adapter, the
# KITTI object map, the loader, the shards, file modes)
_SCORES = ("tests/matcher/test_regions.py", "tests/matcher/test_benchmarks.py",
           "tests/matcher/test_metrics.py", "tests/matcher/test_metrics_properties.py",
           "src/matcher/regions.py", "src/matcher/benchmarks.py", "src/matcher/metrics.py")
_ADAPTERS = ("tests/matcher/test_adapters.py", "src/matcher/adapters.py", "src/matcher/processes.py")
# test_cli's match tests read golden/, which the copy does not hold: the render commands only
_EXPORT = ("tests/synth/test_export.py", "tests/synth/test_cli.py", "-k", "render or obj_map or staged")

MUTANTS += (
    Mutant(
        "validate quantiles as percentiles",
        "src/matcher/regions.py",
        (("np.quantile(err, (0.5, 0.9, 0.99))", "np.percentile(err, (0.5, 0.9, 0.99))"),),
        "a50/a90/a99 of validate and eval-dataset are the 0.5th/0.9th/0.99th percentiles",
        _SCORES,
    ),
    Mutant(
        "benchmark quantiles as percentiles",
        "src/matcher/benchmarks.py",
        (("np.quantile(err, _QUANTILES)", "np.percentile(err, _QUANTILES)"),),
        "a50..a99 of eval --benchmark middlebury/eth3d are the 0.5th..0.99th percentiles",
        _SCORES,
    ),
    Mutant(
        "validate bad-x counts an error equal to x",
        "src/matcher/regions.py",
        (("np.count_nonzero(err <= th)", "np.count_nonzero(err < th)"),),
        "|err| == x is bad in bad_0_5 .. bad_4 (Middlebury: bad is |err| > x)",
        _SCORES,
    ),
    Mutant(
        "MiddEval3 bad-x counts an error equal to x",
        "src/matcher/benchmarks.py",
        (("bad = {th: 100.0 * int((err > th).sum()) / n", "bad = {th: 100.0 * int((err >= th).sum()) / n"),),
        "middlebury_v3 counts |err| == x as bad (evaldisp: err > thresh)",
        _SCORES,
    ),
    Mutant(
        "ETH3D bad-x counts an error equal to x",
        "src/matcher/benchmarks.py",
        (("bad = [_pct(int((err > th).sum()), err.size)", "bad = [_pct(int((err >= th).sum()), err.size)"),),
        "eth3d_two_view counts |err| == x as bad",
        _SCORES,
    ),
    Mutant(
        "OpenCV fixed-point 0 taken as no estimate",
        "src/matcher/processes.py",
        (("out[raw < 0] = np.inf", "out[raw <= 0] = np.inf"),),
        "an int16 compute() result of 0 (disparity 0) becomes inf; only negatives are no estimate",
        _ADAPTERS,
    ),
    Mutant(
        "OpenCV float 0 taken as no estimate",
        "src/matcher/processes.py",
        (("out[out < 0] = np.inf", "out[out <= 0] = np.inf"),),
        "a float compute() result of 0.0 becomes inf",
        _ADAPTERS,
    ),
    Mutant(
        "KITTI obj_map marks pixels without ground truth",
        "src/synth/formats/kitti.py",
        (("background = ~np.isfinite(disp)", "background = np.zeros(disp.shape, bool)"),),
        "obj_map is 1 (foreground) where there is no ground truth instead of KITTI's 0",
        _EXPORT,
    ),
    Mutant(
        "StereoDataset occlusion includes pixels without ground truth",
        "src/synth/dataset/loader.py",
        (('"occlusion": s.mask_left == 128,', '"occlusion": s.mask_left != 255,'),),
        "item['occlusion'] is every pixel not visible in both views, mask 0 included",
        ("tests/synth/test_loader.py",),
    ),
    Mutant(
        "short last shard sealed",
        "src/synth/dataset/storage/shards.py",
        (("self._close(sealed=False)", "self._close(sealed=True)"),),
        "an extended webdataset run keeps the short shard and starts a new one after it",
        ("tests/synth/test_shards.py",),
    ),
    Mutant(
        "atomic writes keep mkstemp's 0600",
        "src/matcher/io/atomic.py",
        (("os.fchmod(fd, _default_mode())", "os.fchmod(fd, 0o600)"),),
        "every file written atomically (datasets, pairs, PFMs) is unreadable by other users",
        ("tests/matcher/test_io_atomic.py", "src/matcher/io/atomic.py"),
    ),
    Mutant(
        "staged output folder keeps mkdtemp's 0700",
        "src/synth/write/export.py",
        (("os.chmod(stage, _default_dir_mode())", "os.chmod(stage, 0o700)"),),
        "render --out, demo and render --from-manifest folders are closed to other users",
        _EXPORT,
    ),
)

# planted in the reading layer of files from elsewhere (matcher.io.files): each must be caught
# by the damaged-tree property test or the untrusted-data tests
_READING = ("tests/synth/test_damaged_trees_properties.py", "tests/synth/test_untrusted_data.py")

MUTANTS += (
    Mutant(
        "reading: a link out of the tree is followed",
        "src/matcher/io/files.py",
        (("    if base is None:\n        return Path(path)",
          "    if True:\n        return Path(path)"),),
        "a dataset's symbolic link makes a reader open any file the user can read",
        _READING,
    ),
    Mutant(
        "reading: a named pipe is opened",
        "src/matcher/io/files.py",
        (("    if not stat.S_ISREG(st.st_mode):\n        raise FormatError(f\"{path}: is {_kind(st.st_mode)}, not a regular file; the {what} must \"\n                          \"be a regular file\")\n    return st",
          "    return st"),
         ("fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, \"O_CLOEXEC\", 0))",
          "fd = os.open(path, os.O_RDONLY)")),
        "a FIFO in a dataset blocks every reader forever",
        _READING,
    ),
)


# planted in the learned matcher, training and validate's gate: each went unnoticed by the tests
# of its module until its pin (the names start with "learned:", "train:" or "validate:")
# the training module's tests but those of learning quality, the docs' example and the
# DataLoader over every layout (minutes each; none reads what these mutants change)
_TRAIN = ("tests/synth/test_train.py", "-m", "not slow", "-k",
          "not lowers_the_loss and not torch_example and not dataloader_with_two_workers")

MUTANTS += (
    Mutant(
        "train: checkpoint written in place",
        "src/synth/jobs/train/checkpoint.py",
        (("    atomic_write_bytes(path, buf.getvalue())", "    path.write_bytes(buf.getvalue())"),),
        "a kill during the write leaves a cut checkpoint in place of the last good one",
        _TRAIN,
    ),
    Mutant(
        "train: --resume accepts another --seed",
        "src/synth/jobs/train/checkpoint.py",
        (("diff = [k for k in want if want[k] != got.get(k)]",
          'diff = [k for k in want if k != "seed" and want[k] != got.get(k)]'),),
        "a run resumed with another seed mixes two runs' batches in one model",
        _TRAIN,
    ),
    Mutant(
        "train: training split includes the validation samples",
        "src/synth/jobs/train/sources.py",
        (("splits[split] = StereoDataset(root, split=split, val_fraction=val_fraction)",
          'splits[split] = StereoDataset(root, split="all" if split == "train" else split, '
          "val_fraction=val_fraction)"),),
        "the validation loss and the chosen aggregation are measured on pairs trained on",
        _TRAIN,
    ),
    Mutant(
        "validate: regression threshold compared with >=",
        "src/synth/validate/differences.py",
        (('and r["verdict"] == "worse" and r["mean"] > points]',
          'and r["verdict"] == "worse" and r["mean"] >= points]'),),
        "--fail-on regression:POINTS fails a difference of exactly POINTS",
        ("tests/synth/test_validate_baseline.py",),
    ),
    Mutant(
        "validate: real scene divisor ignored",
        "src/synth/formats/middlebury2005.py",
        (("return load_middlebury_2005(Path(ref.root) / ref.key, divisor=ref.divisor)",
          "return load_middlebury_2005(Path(ref.root) / ref.key)"),),
        "middlebury:DIR:DIVISOR scores against codes divided by the divisor its folder name says",
        ("tests/synth/test_validate_real.py",),
    ),
    Mutant(
        "learned: interpolated right features not re-normalised",
        "src/matcher/learned/loss.py",
        (("    return F.normalize(mixed, dim=0)", "    return mixed"),),
        "the loss scores a positive between two pixels below a cosine (shorter vector)",
        ("tests/matcher/test_learned.py",),
    ),
)


def _copy_tree(dst: Path) -> None:
    for name in ("src", "tests"):
        shutil.copytree(ROOT / name, dst / name,
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "*.nbi", "*.nbc"))
    for name in ("conftest.py", "pyproject.toml"):
        shutil.copy2(ROOT / name, dst / name)


def _plant(work: Path, mutant: Mutant) -> str:
    path = work / mutant.path
    text = path.read_text()
    for old, new in mutant.edits:
        if old not in text:
            raise LookupError(f"{mutant.path}: target text not found (did the code move?): {old!r}")
        text = text.replace(old, new)
    path.write_text(text)
    old, new = (" ".join(t.split()) for t in mutant.edits[-1])  # one line for the table
    more = f" (+{len(mutant.edits) - 1} alike)" if len(mutant.edits) > 1 else ""
    return f"{old} -> {new}{more}"


def _failed_tests(junit: Path) -> list[str]:
    failed = []
    for case in ET.parse(junit).getroot().iter("testcase"):
        if case.find("failure") is not None or case.find("error") is not None:
            failed.append(f"{case.get('classname', '')}::{case.get('name', '')}")
    return failed


def run_mutant(mutant: Mutant | None, *, test_paths: list[str], python: str) -> dict:
    """Run ``test_paths`` on a copy with ``mutant`` planted (``None``: the unmutated baseline)."""
    with tempfile.TemporaryDirectory(prefix="sf-mutant-") as tmp:
        work = Path(tmp)
        _copy_tree(work)
        change = "(none)"
        try:
            if mutant is not None:
                change = _plant(work, mutant)
        except LookupError as exc:
            return {"mutant": mutant, "change": str(exc), "killed_by": [], "seconds": 0.0}
        # GL tests must run, not skip: a skipped test kills nothing
        env = dict(os.environ, PYTHONPATH=str(work / "src"), HYPOTHESIS_PROFILE="ci",
                   NUMBA_CACHE_DIR=str(work / ".numba"), STEREOFORGE_REQUIRE_GL="1")
        # make sure the copy (not the installed tree) is what gets imported
        where = subprocess.run([python, "-c", "import matcher; print(matcher.__file__)"],
                               cwd=work, env=env, capture_output=True, text=True)
        if not where.stdout.strip().startswith(str(work)):
            raise RuntimeError(f"mutant not imported from the copy: {where.stdout}{where.stderr}")
        junit = work / "junit.xml"
        t0 = time.perf_counter()
        subprocess.run(
            [python, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--junitxml={junit}",
             "--hypothesis-profile=ci", *test_paths],
            cwd=work, env=env, capture_output=True, text=True,
        )
        seconds = time.perf_counter() - t0
        killed = _failed_tests(junit) if junit.exists() else ["<pytest crashed>"]
        return {"mutant": mutant, "change": change, "killed_by": killed, "seconds": seconds}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("-k", action="append", default=[],
                        help="only mutants whose name contains this text (repeatable: any of them)")
    parser.add_argument("--list", action="store_true", help="list the mutants and exit")
    parser.add_argument("--under", action="append", default=[],
                        help="only mutants of files under this path (repeatable), e.g. src/synth")
    parser.add_argument("--tests", nargs="*", default=None,
                        help="test paths run against every mutant (default: each mutant's own; "
                             "the matcher tests for matcher mutants)")
    parser.add_argument("--no-baseline", action="store_true",
                        help="skip the run of each test set on the unmutated copy")
    args = parser.parse_args(argv)
    chosen = [m for m in MUTANTS if (not args.k or any(k in m.name for k in args.k))
              and (not args.under or any(m.path.startswith(u) for u in args.under))]
    if args.list:
        for m in chosen:
            print(f"- {m.name} ({m.path}): {m.why}")
        return 0
    python = sys.executable

    def tests_of(m: Mutant) -> list[str]:
        return list(args.tests or m.tests or ("tests/matcher", "src/matcher"))

    if not args.no_baseline:
        for tests in sorted({tuple(tests_of(m)) for m in chosen}):
            print(f"baseline: {' '.join(tests)} ...", file=sys.stderr, flush=True)
            base = run_mutant(None, test_paths=list(tests), python=python)
            if base["killed_by"]:
                print(f"the unmutated tree fails {' '.join(tests)}: {base['killed_by'][:5]}",
                      file=sys.stderr)
                return 2
    rows = []
    for m in chosen:
        print(f"planting: {m.name} ...", file=sys.stderr, flush=True)
        rows.append(run_mutant(m, test_paths=tests_of(m), python=python))
    print("| mutant | file | change | killed | tests that kill it | s |")
    print("|---|---|---|---|---|---|")
    survivors = 0
    for r in rows:
        m, killed = r["mutant"], r["killed_by"]
        ok = bool(killed)
        survivors += not ok
        distinct = sorted({k.split("::")[-1].split("[")[0] for k in killed})
        names = ", ".join(distinct[:5]) if killed else "-"
        extra = f" (+{len(distinct) - 5} more)" if len(distinct) > 5 else ""
        print(f"| {m.name} | {m.path} | `{r['change']}` | {'yes' if ok else '**NO**'} "
              f"({len(killed or [])}) | {names}{extra} | {r['seconds']:.0f} |")
    print(f"\n{len(rows) - survivors}/{len(rows)} mutants killed")
    return 1 if survivors else 0


if __name__ == "__main__":
    sys.exit(main())
