"""Properties of synth.dataset.compare: encodings never count as content, changed pixels do."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from matcher.io import DEFLATES, encode_pfm, encode_png
from synth.dataset.compare import compare_files

_images = st.one_of(
    arrays(np.uint8, st.tuples(st.integers(1, 24), st.integers(1, 24))),
    arrays(np.uint8, st.tuples(st.integers(1, 16), st.integers(1, 16), st.just(3))),
    arrays(np.uint16, st.tuples(st.integers(1, 16), st.integers(1, 16))),
)


@given(_images)
def test_two_deflates_of_one_image_differ_by_encoding_only(image):
    found = compare_files("x.png", encode_png(image, deflate="isal"),
                           encode_png(image, deflate="zlib"))
    assert all(d.kind == "encoding" for d in found)  # empty when the two encoders agree


@given(_images, st.data())
def test_changed_pixels_are_counted_exactly(image, data):
    h, w = image.shape[:2]
    flat = data.draw(st.sets(st.integers(0, h * w - 1), min_size=1, max_size=h * w))
    changed = image.copy()
    for k in flat:
        changed[divmod(k, w)] ^= 1  # every channel of the pixel, by one grey level
    (found,) = compare_files("x.png", encode_png(image), encode_png(changed))
    first = divmod(min(flat), w)
    assert found.kind == "content"
    assert found.detail.startswith(f"{len(flat)} of {h * w} pixels differ, largest "
                                   f"|difference| 1; first at row {first[0]}, column {first[1]}")


@given(arrays(np.float32, st.tuples(st.integers(1, 12), st.integers(1, 12)),
              elements=st.floats(0, 1e4, width=32) | st.just(np.inf)))
def test_a_pfm_equals_itself_and_a_changed_value_is_found(disp):
    assert compare_files("d.pfm", encode_pfm(disp), encode_pfm(disp.copy())) == []
    changed = disp.copy()
    changed.flat[-1] = -1.0  # never among the drawn values
    (found,) = compare_files("d.pfm", encode_pfm(disp), encode_pfm(changed))
    assert found.kind == "content" and found.detail.startswith(f"1 of {disp.size} values differ")
