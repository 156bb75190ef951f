"""Property tests of the learned matcher's torch pipeline (:mod:`matcher.learned.volume`)
against the numba path it must equal, beside a hand-picked example: integer disparities and the
invalid mask exactly, sub-pixel values within 1e-4 px, for any size, range, box, LR check and
tolerance."""

from __future__ import annotations

import importlib.util
import os

import numpy as np
import pytest

if importlib.util.find_spec("torch") is None:  # the extra 'learn'
    if os.environ.get("STEREOFORGE_REQUIRE_TORCH", "") not in ("", "0"):
        raise RuntimeError("torch is not installed and STEREOFORGE_REQUIRE_TORCH=1 forbids skipping")
    pytest.skip("torch is not installed (pip install 'stereoforge[learn]')", allow_module_level=True)

import torch  # noqa: E402
from hypothesis import given  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from matcher.learned import Architecture, PatchNet, match_learned  # noqa: E402
from matcher.learned.model import LearnedModel  # noqa: E402

torch.manual_seed(11)
_MODEL = LearnedModel(net=PatchNet(Architecture(channels=6, layers=2)).eval())


def _check(left, right, **kw):
    a = match_learned(left, right, _MODEL, pipeline="numba", **kw).disparity
    b = match_learned(left, right, _MODEL, pipeline="torch", **kw).disparity
    np.testing.assert_array_equal(np.isinf(a), np.isinf(b))
    ok = np.isfinite(a)
    np.testing.assert_array_equal(a[ok] == np.floor(a[ok]), b[ok] == np.floor(b[ok]))
    whole = ok & (a == np.floor(a))
    np.testing.assert_array_equal(a[whole], b[whole])
    np.testing.assert_allclose(b[ok], a[ok], rtol=0, atol=1e-4)


@given(h=st.integers(1, 24), w=st.integers(2, 48), data=st.data(),
       aggregate=st.sampled_from([1, 3, 5, 9]), lr_check=st.booleans(),
       lr_tolerance=st.integers(0, 3), subpixel=st.booleans(), seed=st.integers(0, 2**16),
       flat=st.booleans())
def test_torch_pipeline_equals_numba(h, w, data, aggregate, lr_check, lr_tolerance, subpixel,
                                     seed, flat):
    n_disp = data.draw(st.integers(1, w - 1), label="max_disparity")
    rng = np.random.default_rng(seed)
    levels = 3 if flat else 256  # few grey levels: many equal costs, ties to the smallest d
    left = rng.integers(0, levels, (h, w), dtype=np.uint8)
    right = rng.integers(0, levels, (h, w), dtype=np.uint8)
    _check(left, right, max_disparity=n_disp, aggregate=aggregate, lr_check=lr_check,
           lr_tolerance=lr_tolerance, subpixel=subpixel)


def test_torch_pipeline_equals_numba_on_a_constant_pair():
    """Every cost equal: every pixel ties at d = 0, in both views."""
    img = np.full((6, 10), 77, np.uint8)
    _check(img, img, max_disparity=9, aggregate=3, lr_check=True, subpixel=True)
    d = match_learned(img, img, _MODEL, max_disparity=9, pipeline="torch").disparity
    assert not d.any()
