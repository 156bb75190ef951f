"""MATCHER strings with real tiny matchers: a SAD in this file, a program, crashing and hanging ones."""

from __future__ import annotations

import os
import sys
import time

import cv2
import numpy as np
import pytest

from matcher.adapters import MatcherError, MatcherFailure, resolve_matcher

HERE = os.path.abspath(__file__)


def sad_matcher(left, right, *, max_disparity):
    """A 20-line SAD block matcher: 5x5 box of absolute differences, winner takes all."""
    gl = left.astype(np.float32).mean(axis=2)
    gr = right.astype(np.float32).mean(axis=2)
    h, w = gl.shape
    costs = np.full((max_disparity, h, w), np.inf, np.float32)
    for d in range(max_disparity):
        diff = np.abs(gl[:, d:] - gr[:, : w - d])
        costs[d, :, d:] = cv2.boxFilter(diff, -1, (5, 5), normalize=False)
    disp = costs.argmin(axis=0).astype(np.float32)
    disp[:, :max_disparity] = np.nan  # no estimate where the search leaves the right image
    return disp


def crashing(left, right, *, max_disparity):
    raise RuntimeError("boom at pixel (3, 4)")


def aborting(left, right, *, max_disparity):
    os.abort()


def sleeping(left, right, *, max_disparity):
    time.sleep(30)
    return np.zeros(left.shape[:2], np.float32)


def wrong_shape(left, right, *, max_disparity):
    return np.zeros((10, 12), np.float32)


def wrong_dtype(left, right, *, max_disparity):
    return np.zeros(left.shape[:2], bool)


def not_an_array(left, right, *, max_disparity):
    return "a disparity"


opencv_bm = cv2.StereoBM_create(numDisparities=16, blockSize=5)


class _FixedCompute:
    """An OpenCV-style matcher whose ``compute`` returns ``raw``: 0 (a real disparity of 0)
    beside negatives (no estimate), in OpenCV's int16 fixed point and as float."""

    def __init__(self, dtype, scale):
        raw = np.zeros((40, 64), dtype)
        raw[:, 1] = -1 * scale
        raw[:, 2] = 3 * scale
        self.raw = raw

    def compute(self, left, right):
        return self.raw


fixed_int16 = _FixedCompute(np.int16, 16)
fixed_float = _FixedCompute(np.float32, 1)

_PROGRAM = """\
import sys
import numpy as np
from matcher.io import read_image, write_pfm
left, right, out, d = read_image(sys.argv[1]), read_image(sys.argv[2]), sys.argv[3], int(sys.argv[4])
assert left.shape == right.shape and left.dtype == np.uint8, (left.shape, left.dtype)
write_pfm(out, np.full(left.shape[:2], min(3, d - 1), np.float32))
"""


@pytest.fixture(scope="module")
def pair():
    rng = np.random.default_rng(1)
    right = rng.integers(0, 256, (40, 64, 3), dtype=np.uint8)
    right = cv2.GaussianBlur(right, (3, 3), 0)
    left = np.roll(right, 4, axis=1)
    return np.ascontiguousarray(left), np.ascontiguousarray(right)


def test_builtin_names_and_windows(pair):
    m = resolve_matcher("ct:5")
    assert (m.spec, m.name, m.kind) == ("ct:5", "ct:5", "builtin")
    assert resolve_matcher("sgbm").name == "sgbm:9"
    out = m.run(*pair, max_disparity=8)
    assert out.error is None and out.disparity.dtype == np.float32
    assert np.median(out.disparity[:, 10:-5]) == 4.0


def test_python_file_sad_matcher(pair):
    m = resolve_matcher(f"py:{HERE}:sad_matcher", timeout=60)
    try:
        out = m.run(*pair, max_disparity=8)
        assert out.error is None, out.error
        assert out.disparity.shape == (40, 64)
        assert np.isinf(out.disparity[:, :8]).all()  # the NaN of the user became inf
        assert np.median(out.disparity[:, 10:-5]) == 4.0
        assert out.seconds > 0
        assert np.array_equal(m(*pair, max_disparity=8), out.disparity)  # the child is reused
    finally:
        m.close()


def test_opencv_compute_object_gets_grey_and_fixed_point_is_divided(pair):
    m = resolve_matcher(f"py:{HERE}:opencv_bm")
    try:
        out = m.run(*pair, max_disparity=16)
        assert out.error is None, out.error
        ref = opencv_bm.compute(cv2.cvtColor(pair[0], cv2.COLOR_RGB2GRAY),
                                cv2.cvtColor(pair[1], cv2.COLOR_RGB2GRAY))
        expected = ref.astype(np.float32) / 16
        expected[ref < 0] = np.inf
        assert np.array_equal(out.disparity, expected)
    finally:
        m.close()


@pytest.mark.parametrize("name", ["fixed_int16", "fixed_float"])
def test_opencv_compute_result_0_is_disparity_0_and_only_negatives_are_no_estimate(pair, name):
    m = resolve_matcher(f"py:{HERE}:{name}")
    try:
        out = m.run(*pair, max_disparity=16)
        assert out.error is None, out.error
        expected = np.zeros((40, 64), np.float32)
        expected[:, 1], expected[:, 2] = np.inf, 3.0
        assert np.array_equal(out.disparity, expected)
    finally:
        m.close()


@pytest.mark.parametrize("func, message", [
    ("crashing", "crashed: RuntimeError: boom at pixel (3, 4)"),
    ("wrong_shape", "returned shape (10, 12), expected (40, 64)"),
    ("wrong_dtype", "returned dtype bool"),
    ("not_an_array", "returned a str"),
])
def test_failures_are_recorded_not_raised(pair, func, message):
    m = resolve_matcher(f"py:{HERE}:{func}")
    try:
        out = m.run(*pair, max_disparity=8)
        assert out.disparity is None and out.error.startswith(message), out.error
        with pytest.raises(MatcherFailure, match="^" + message[:12]):
            m(*pair, max_disparity=8)
    finally:
        m.close()


def test_a_dying_process_is_a_crash_and_the_next_call_starts_a_new_one(pair):
    m = resolve_matcher(f"py:{HERE}:aborting")
    out = m.run(*pair, max_disparity=8)
    assert out.error.startswith("crashed: the matcher's process died"), out.error
    out = m.run(*pair, max_disparity=8)  # a fresh child, which dies again
    assert out.error.startswith("crashed:"), out.error
    m.close()


def test_a_hung_callable_times_out_and_is_killed(pair):
    m = resolve_matcher(f"py:{HERE}:sleeping", timeout=1.0)
    start = time.perf_counter()
    out = m.run(*pair, max_disparity=8)
    assert out.error == "timed out after 1 s"
    assert time.perf_counter() - start < 20
    assert m._child.proc is None  # killed, not left running


def test_program_matcher_pfm(tmp_path, pair):
    script = tmp_path / "a dir with spaces" / "prog.py"
    script.parent.mkdir()
    script.write_text(_PROGRAM)
    m = resolve_matcher(f"cmd:{sys.executable} '{script}' {{left}} {{right}} {{out}} {{max_disparity}}")
    assert m.kind == "cmd"
    out = m.run(*pair, max_disparity=8)
    assert out.error is None, out.error
    assert (out.disparity == 3).all()


def test_program_matcher_png_and_failures(tmp_path, pair):
    png = ("import sys, numpy as np, cv2; "
           "cv2.imwrite(sys.argv[1], np.full((40, 64), 512, np.uint16))")
    m = resolve_matcher(f'cmd:{sys.executable} -c "{png}" {{out_png}} {{left}} {{right}}')
    out = m.run(*pair, max_disparity=8)
    assert out.error is None, out.error
    assert (out.disparity == 2).all()
    bad = resolve_matcher(f'cmd:{sys.executable} -c "import sys; sys.exit(3)" {{left}} {{right}} {{out}}')
    assert bad.run(*pair, max_disparity=8).error.startswith("crashed: exit status 3")
    silent = resolve_matcher(f'cmd:{sys.executable} -c "pass" {{left}} {{right}} {{out}}')
    assert silent.run(*pair, max_disparity=8).error == "wrote no {out} file (exit status 0)"
    garbage = resolve_matcher(f'cmd:{sys.executable} -c "import sys; open(sys.argv[1], \'w\')'
                              f'.write(\'not a pfm\')" {{out}} {{left}} {{right}}')
    assert garbage.run(*pair, max_disparity=8).error.startswith("wrote an unreadable disp0.pfm: ")
    slow = resolve_matcher(f'cmd:sleep 30; echo {{left}} {{right}} {{out}}', timeout=0.5)
    start = time.perf_counter()
    assert slow.run(*pair, max_disparity=8).error == "timed out after 0.5 s"
    assert time.perf_counter() - start < 10


@pytest.mark.parametrize("spec, fragment", [
    ("sad", "tried a built-in method 'sad'"),
    ("ct:8", "odd integer >= 3"),
    ("bm:3", "StereoBM needs a window >= 5"),
    ("py:no_such_module_xyz:f", "tried importing the module 'no_such_module_xyz'"),
    ("py:/no/such/file.py:f", "tried the file /no/such/file.py: it does not exist"),
    (f"py:{HERE}:no_such_function", "has no attribute 'no_such_function'"),
    (f"py:{HERE}", "':FUNCTION' part is missing"),
    (f"py:{HERE}:HERE", "neither callable nor an object with compute"),
    ("cmd:echo {left}", "missing: {right}, {out or out_png}"),
    ("", "expected a MATCHER string"),
])
def test_strings_that_do_not_resolve_say_what_was_tried(spec, fragment):
    with pytest.raises(MatcherError) as info:
        resolve_matcher(spec)
    assert fragment in str(info.value)
    assert isinstance(info.value, ValueError)


def test_the_child_of_a_py_matcher_dies_with_its_parent(tmp_path):
    import signal
    import subprocess

    import psutil

    code = (f"import numpy as np, sys\n"
            f"from matcher.adapters import resolve_matcher\n"
            f"m = resolve_matcher('py:{HERE}:sleeping', timeout=600)\n"
            f"print('go', flush=True)\n"
            f"m.run(np.zeros((8, 8, 3), np.uint8), np.zeros((8, 8, 3), np.uint8), max_disparity=2)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE)
    try:
        assert proc.stdout.readline().strip() == b"go"
        parent = psutil.Process(proc.pid)
        deadline = time.monotonic() + 60
        while not parent.children(recursive=True):
            assert time.monotonic() < deadline, "the matcher's child process did not start"
            time.sleep(0.05)
        time.sleep(1.0)  # let it reach the user's call
        children = parent.children(recursive=True)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        gone, alive = psutil.wait_procs(children, timeout=20)
        assert not alive, alive
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stdout.close()
