"""Datasets from elsewhere are untrusted: a property test over randomly damaged trees of every
layout with sample folders. Whatever the damage (a file cut, resized, re-moded, replaced by
noise, by a named pipe or by a link out of the tree, a record edited to name a path outside),
every reader (``StereoDataset``, the layout's own reading through a SPEC, ``dataset --verify``)
ends within a time limit with a result or its documented error, and opens nothing outside the
dataset's root."""

from __future__ import annotations

import json
import os
import shutil
import signal
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from matcher.io import encode_png
from stereoforge.errors import DatasetError, StereoforgeError
from synth.dataset.config.parse import loads_config
from synth.dataset.run import run_dataset
from synth.formats import get_layout

pytestmark = pytest.mark.gl

CONFIG = """\
name = "damaged"
seed = 3
count = 2

[rig]
width = 32
height = 24

[scene]
base = "flying"

[photometric]
noise_sigma = 2.0
"""
LAYOUTS = ("middlebury", "middlebury2014", "kitti", "sceneflow", "crestereo", "fsd")
DAMAGES = ("truncate", "noise", "resize", "grey", "fifo", "link_out", "empty", "record_abs",
           "record_up", "folder")
#: Seconds a reader may take on a damaged tree of two 32 x 24 samples.
LIMIT_S = 20


@pytest.fixture(scope="module")
def pristine(tmp_path_factory, renderer) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("pristine")
    out = {}
    for name in LAYOUTS:
        out[name] = base / name
        run_dataset(loads_config(CONFIG), out=out[name], fmt=name, progress=False)
    return out


class _Alarm(Exception):
    pass


def _on_alarm(_signum, _frame):
    raise _Alarm()


def _files(root: Path) -> list[Path]:
    return sorted(p for p in root.rglob("*") if p.is_file() and p.name != ".lock")


def _damage(root: Path, outside: Path, how: str, pick: int) -> str:
    """Damage one file of the tree ``root`` (the ``pick``-th); what was done."""
    files = _files(root)
    records = [p for p in files if p.parent.name == "records"]
    if how.startswith("record") and records:
        path = records[pick % len(records)]
        doc = json.loads(path.read_text())
        name = next(iter(doc["files"]))
        target = str(outside) if how == "record_abs" else f"../../{outside.name}"
        doc["files"][target] = doc["files"].pop(name)
        path.write_text(json.dumps(doc))
        return f"{path.relative_to(root)}: {name} -> {target}"
    path = files[pick % len(files)]
    rel = path.relative_to(root)
    if how == "truncate":
        path.write_bytes(path.read_bytes()[: max(1, path.stat().st_size // 3)])
    elif how == "noise":
        path.write_bytes(np.random.default_rng(pick).bytes(max(8, path.stat().st_size)))
    elif how == "resize":
        path.write_bytes(encode_png(np.zeros((7, 5, 3), np.uint8)))
    elif how == "grey":
        path.write_bytes(encode_png(np.full((24, 32), 9, np.uint8)))
    elif how == "fifo":
        path.unlink()
        os.mkfifo(path)
    elif how == "link_out":
        path.unlink()
        path.symlink_to(outside)
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "folder":
        path.unlink()
        path.mkdir()
    return f"{rel}: {how}"


def _opened_outside(root: Path, watched: Path, calls) -> list[str]:
    """The paths among ``calls`` (audit 'open' events) under ``watched`` but outside ``root``."""
    out = []
    for path in calls:
        try:
            resolved = Path(path).resolve()
        except (OSError, RuntimeError, TypeError, ValueError):
            continue
        if watched in resolved.parents and root.resolve() not in resolved.parents \
                and resolved != root.resolve():
            out.append(str(resolved))
    return out


_OPENED: list = []
_WATCH = {"on": False}


def _audit(event, args):
    if _WATCH["on"] and event == "open" and args and isinstance(args[0], (str, bytes, Path)):
        _OPENED.append(os.fsdecode(args[0]) if not isinstance(args[0], Path) else str(args[0]))


sys.addaudithook(_audit)


def _run(reader, what: str, errors: tuple[type, ...]) -> str:
    """Run ``reader`` under the time limit; its outcome, or fail if it raised another type."""
    old = signal.signal(signal.SIGALRM, _on_alarm)
    signal.setitimer(signal.ITIMER_REAL, LIMIT_S)
    try:
        reader()
        return "ok"
    except _Alarm:
        pytest.fail(f"{what}: still running after {LIMIT_S} s")
    except errors as exc:
        assert "\n" not in str(exc).strip(), (what, str(exc))
        return f"{type(exc).__name__}"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


@settings(suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
          deadline=None)
@given(layout=st.sampled_from(LAYOUTS), damages=st.lists(
    st.tuples(st.sampled_from(DAMAGES), st.integers(0, 10**6)), min_size=1, max_size=2))
def test_every_reader_of_a_damaged_tree_ends_with_a_result_or_its_error(pristine, tmp_path,
                                                                         layout, damages):
    from synth.dataset.loader import StereoDataset
    from synth.dataset.storage.integrity import verify_dataset
    from synth.formats import resolve_spec

    work = tmp_path / f"case-{len(list(tmp_path.iterdir()))}"
    root = work / "dataset"
    shutil.copytree(pristine[layout], root, symlinks=True)
    outside = work / "secret.txt"  # what no reader may open
    outside.write_bytes(b"not part of the dataset\n")
    done = [_damage(root, outside, how, pick) for how, pick in damages]

    def every_item():
        data = StereoDataset(root)
        for i in range(len(data)):
            data[i]

    def through_the_spec():
        scheme = get_layout(layout).scheme or "middlebury"
        spec_root = root / get_layout(layout).sample_parent if scheme == "middlebury" else root
        for ref in resolve_spec(f"{scheme}:{spec_root}"):
            ref.read()

    _OPENED.clear()
    _WATCH["on"] = True
    try:
        outcomes = [_run(every_item, f"StereoDataset {done}", (DatasetError,)),
                    _run(through_the_spec, f"{layout} SPEC {done}",
                         (StereoforgeError, FileNotFoundError)),
                    _run(lambda: verify_dataset(root), f"--verify {done}", (StereoforgeError,))]
    finally:
        _WATCH["on"] = False
    assert _opened_outside(root, work, _OPENED) == [], (layout, done, outcomes)


def test_a_hand_picked_damage_of_each_kind(pristine, tmp_path):
    """The property's hand-picked twin: every damage once on the middlebury tree, and the
    named pipe on every layout (the case that blocked readers forever)."""
    for case, (layout, how) in enumerate([*(("middlebury", d) for d in DAMAGES),
                                           *((name, "fifo") for name in LAYOUTS)]):
        test_every_reader_of_a_damaged_tree_ends_with_a_result_or_its_error.hypothesis \
            .inner_test(pristine, tmp_path, layout, [(how, case)])
