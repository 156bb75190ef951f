"""The property battery of ``stereoforge validate``: what any stereo matcher must get right.

:func:`run_battery` runs each property of :data:`PROPERTIES` with hypothesis on a matcher
``f(left, right, *, max_disparity) -> (H, W) array`` (``inf``/NaN = no estimate) called with
(H, W, 3) uint8 RGB views, and writes ``properties.json`` and, for each failure, the shrunk
counterexample as PNGs (``left``, ``right``, ``expected``, ``answer``; disparities colour-mapped
over ``0 .. max_disparity``, black = no estimate) under ``properties/<name>/``.

Every image is generated with numpy (no GL): the pairs of :mod:`matcher.testing` where they fit,
and Fourier-shifted band-limited noise for sub-pixel shifts. Scores are taken on the *interior*:
:data:`MARGIN` pixels from every side, and the :data:`MAX_DISPARITY` leftmost columns too (where a
matcher may rightly have no match). ``bad-x`` is the fraction of interior pixels with
``|error| > x`` or no estimate. Thresholds leave room for real matchers (CT-9 and OpenCV SGBM pass
every required property; ``tests/synth/test_validate_properties.py`` checks it, and that
matchers returning zeros, an answer off by one pixel, the wrong shape, or raising fail).

Runs are deterministic (``derandomize=True``, no example database): the same matcher gives the
same ``properties.json``. A matcher that raises, or returns something that is not an (H, W)
real array, fails the property with what it did; the battery itself never stops.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, Phase, Verbosity, given, settings
from hypothesis import strategies as st

from matcher.io import atomic_write_bytes, encode_png
from matcher.testing import grey_images, monotone_maps, piecewise_planar_pairs, shifted_pairs, textured_images
from stereoforge.errors import ParameterError

__all__ = ["MARGIN", "MAX_DISPARITY", "MAX_TIMEOUTS", "PROPERTIES", "SUITES", "Property", "run_battery"]

#: Disparity search range the battery asks for (``max_disparity=``).
MAX_DISPARITY = 16
#: Pixels left out of the scores at every image side (a 17 x 17 window's half side).
MARGIN = 8
#: Suites: examples per property and matcher calls allowed for shrinking one failure.
SUITES = {"quick": {"examples": 10, "shrink_calls": 30}, "full": {"examples": 60, "shrink_calls": 300}}


# --------------------------------------------------------------------------- cases and calls
@dataclass(frozen=True, eq=False)
class _Case:
    """One generated input: grey views, their true disparity (if known), and a description."""

    left: np.ndarray
    right: np.ndarray
    truth: np.ndarray | None
    what: str
    extra: tuple = ()

    def key(self) -> str:
        h = hashlib.sha1(self.left.tobytes() + b"|" + self.right.tobytes())
        h.update(repr((self.left.shape, self.extra)).encode())
        return h.hexdigest()


class _MatcherFault(Exception):
    """The matcher raised or returned something unusable (message: what it did)."""


#: After this many timed-out calls the matcher is not called again (each may cost a --timeout).
MAX_TIMEOUTS = 2


@dataclass
class _Caller:
    """Calls the matcher with RGB views; turns whatever goes wrong into :class:`_MatcherFault`.

    A :class:`matcher.adapters.MatcherFailure` (what an adapter raises: ``"crashed: ..."``,
    ``"timed out after 60 s"``, ...) is reported with its own message; after
    :data:`MAX_TIMEOUTS` time-outs the matcher is not called again.
    """

    matcher: Callable[..., np.ndarray]
    calls: int = 0
    timeouts: int = 0

    def __call__(self, left: np.ndarray, right: np.ndarray) -> np.ndarray:
        if self.timeouts >= MAX_TIMEOUTS:
            raise _MatcherFault(f"not called: it timed out {self.timeouts} times already")
        self.calls += 1
        rgb_l, rgb_r = (np.repeat(v[..., None], 3, axis=2) for v in (left, right))
        try:
            value = self.matcher(rgb_l, rgb_r, max_disparity=MAX_DISPARITY)
        except Exception as exc:  # noqa: BLE001 - any failure of the user's code is a result
            text = (str(exc).strip().splitlines() or [""])[0][:200]
            if type(exc).__name__ == "MatcherFailure":  # matcher.adapters: already one line
                self.timeouts += text.startswith("timed out")
                raise _MatcherFault(text) from None
            raise _MatcherFault(f"raised {type(exc).__name__}: {text}".rstrip(": ")) from None
        return _check_answer(value, left.shape)


def _check_answer(value: object, shape: tuple[int, int]) -> np.ndarray:
    """``value`` as an (H, W) float64 array with ``inf`` for no estimate, or :class:`_MatcherFault`."""
    if not isinstance(value, np.ndarray):
        raise _MatcherFault(f"returned {type(value).__name__}, expected a {shape} float array")
    if value.ndim == 3 and value.shape[2] == 1:
        value = value[..., 0]
    if value.shape != shape:
        raise _MatcherFault(f"returned shape {value.shape}, expected {shape}")
    if value.dtype == np.bool_ or not (np.issubdtype(value.dtype, np.floating)
                                       or np.issubdtype(value.dtype, np.integer)):
        raise _MatcherFault(f"returned dtype {value.dtype}, expected a float (or integer) array")
    out = value.astype(np.float64)
    out[np.isnan(out)] = np.inf
    return out


@dataclass
class _Outcome:
    passed: bool
    badness: float  # larger is worse; ranks the examples that passed
    text: str  # one line, with the measured figure and the threshold
    images: dict[str, np.ndarray] = field(default_factory=dict)


# --------------------------------------------------------------------------- measures
def _interior(shape: tuple[int, int]) -> np.ndarray:
    mask = np.zeros(shape, dtype=bool)
    mask[MARGIN:-MARGIN, MAX_DISPARITY + MARGIN:-MARGIN] = True
    return mask


def _bad(answer: np.ndarray, truth: np.ndarray, mask: np.ndarray, tau: float) -> float:
    wrong = ~np.isfinite(answer) | (np.abs(answer - truth) > tau)
    return float(wrong[mask].mean())


def _disagree(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    """Fraction of ``mask`` where ``a`` and ``b`` differ by more than 1 px or in validity."""
    fa, fb = np.isfinite(a), np.isfinite(b)
    same = (fa & fb & (np.abs(np.where(fa, a, 0) - np.where(fb, b, 0)) <= 1.0)) | (~fa & ~fb)
    return float((~same)[mask].mean())


def _images(case: _Case, expected: np.ndarray | None, answer: np.ndarray | None) -> dict:
    out = {"left": case.left, "right": case.right}
    if expected is not None:
        out["expected"] = expected
    if answer is not None:
        out["answer"] = answer
    return out


def _accuracy(tau: float, threshold: float, label: str = "") -> Callable[[_Caller, _Case], _Outcome]:
    """A check: bad-``tau`` of the answer against the case's truth on the interior."""

    def check(call: _Caller, case: _Case) -> _Outcome:
        answer = call(case.left, case.right)
        bad = _bad(answer, case.truth, _interior(case.left.shape) & _truth_mask(case), tau)
        return _Outcome(bad <= threshold, bad,
                        f"bad-{tau:g} {100 * bad:.1f} % on {case.what}{label}, threshold "
                        f"{100 * threshold:g} %", _images(case, case.truth, answer))

    return check


def _truth_mask(case: _Case) -> np.ndarray:
    """Pixels whose truth is reliable: away from the pieces' boundaries (``extra[0]`` = labels)."""
    if not case.extra or not isinstance(case.extra[0], np.ndarray):
        return np.ones(case.left.shape, dtype=bool)
    labels = case.extra[0]
    from scipy.ndimage import maximum_filter, minimum_filter

    size = 2 * MARGIN + 1
    return maximum_filter(labels, size=size) == minimum_filter(labels, size=size)


def _check_identical(call: _Caller, case: _Case) -> _Outcome:
    answer = call(case.left, case.left)
    zero = np.zeros(case.left.shape)
    bad = _bad(answer, zero, _interior(case.left.shape), 0.5)
    limit = 0.05
    return _Outcome(bad <= limit, bad, f"{100 * bad:.1f} % of interior pixels not 0 (±0.5 px) "
                    f"with identical views of {case.what}, threshold {100 * limit:g} %",
                    _images(_Case(case.left, case.left, None, case.what), zero, answer))


def _check_mirror(call: _Caller, case: _Case) -> _Outcome:
    first = call(case.left, case.right)
    second = call(np.fliplr(case.right).copy(), np.fliplr(case.left).copy())
    h, w = case.left.shape
    mask = np.zeros((h, w), dtype=bool)
    mask[MARGIN:-MARGIN, MAX_DISPARITY + MARGIN:w - MAX_DISPARITY - MARGIN] = True
    mask &= _truth_mask(case)
    off = _disagree(np.fliplr(second), first, mask)
    limit = 0.10
    mirrored = _Case(np.fliplr(case.right), np.fliplr(case.left), None, case.what)
    return _Outcome(off <= limit, off, f"mirrored answer differs from the mirrored pair's answer "
                    f"(> 1 px or validity) at {100 * off:.1f} % of pixels on {case.what}, "
                    f"threshold {100 * limit:g} %", _images(mirrored, np.fliplr(first), second))


def _check_translation(call: _Caller, case: _Case) -> _Outcome:
    labels, dy, dx = case.extra
    first = call(case.left, case.right)
    crop = _Case(case.left[dy:, dx:].copy(), case.right[dy:, dx:].copy(), None, case.what,
                 (labels[dy:, dx:],))
    second = call(crop.left, crop.right)
    off = _disagree(second, first[dy:, dx:], _interior(crop.left.shape) & _truth_mask(crop))
    limit = 0.10
    return _Outcome(off <= limit, off, f"answer on the pair cropped by ({dy}, {dx}) px differs "
                    f"from the cropped answer at {100 * off:.1f} % of pixels on {case.what}, "
                    f"threshold {100 * limit:g} %", _images(crop, first[dy:, dx:], second))


def _check_border(call: _Caller, case: _Case) -> _Outcome:
    answer = call(case.left, case.right)
    h, w = answer.shape
    cols = np.broadcast_to(np.arange(w, dtype=np.float64), (h, w))
    strip = np.zeros((h, w), dtype=bool)
    strip[MARGIN:-MARGIN, :MAX_DISPARITY] = True
    impossible = np.isfinite(answer) & (answer > cols + 0.5)
    frac = float(impossible[strip].mean())
    limit = 0.02
    truth = np.where(cols >= case.truth, case.truth, np.inf)
    return _Outcome(frac <= limit, frac, f"{100 * frac:.1f} % of the {MAX_DISPARITY} left border "
                    "columns claim a match outside the right image (d > x) on "
                    f"{case.what}, threshold {100 * limit:g} %", _images(case, truth, answer))


def _check_contract(call: _Caller, case: _Case) -> _Outcome:
    call(case.left, case.right)  # shape and dtype are checked by the call
    return _Outcome(True, 0.0, f"an (H, W) real array on {case.what}", {})


def _check_invalid_marking(call: _Caller, case: _Case) -> _Outcome:
    answer = call(case.left, case.right)
    finite = np.isfinite(answer)
    outside = finite & ((answer < 0) | (answer > MAX_DISPARITY))
    frac = float(outside.mean())
    where = f" (e.g. {answer[outside].flat[0]:g})" if outside.any() else ""
    return _Outcome(frac == 0.0, frac, f"{100 * frac:.1f} % of pixels hold finite values outside "
                    f"[0, {MAX_DISPARITY}]{where} on {case.what}; no estimate must be inf or NaN, "
                    "threshold 0 %", _images(case, case.truth, answer))


# --------------------------------------------------------------------------- strategies
def _shifts(smooth: tuple[float, float] = (0.0, 1.0)) -> st.SearchStrategy[_Case]:
    def case(p) -> _Case:
        return _Case(p.left, p.right, np.full(p.left.shape, float(p.shift)),
                     f"a {p.shift} px shift of noise, {p.left.shape[1]} x {p.left.shape[0]}")

    return shifted_pairs(max_shift=12, min_side=48, max_side=72, smooth=smooth).map(case)


@st.composite
def _subpixel_shifts(draw) -> _Case:
    """Band-limited noise shifted by a non-integer amount, exactly (Fourier phase shift)."""
    h, w = draw(st.integers(48, 64)), draw(st.integers(56, 72))
    shift = draw(st.integers(2, 46)) / 4.0
    shift = shift + 0.25 if shift == int(shift) else shift
    sigma = draw(st.floats(1.5, 2.5))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    from scipy.ndimage import gaussian_filter

    n = w + 32
    strip = gaussian_filter(rng.random((h, n)), sigma, mode="wrap")
    k = np.fft.fftfreq(n)
    moved = np.real(np.fft.ifft(np.fft.fft(strip, axis=1) * np.exp(2j * np.pi * k * shift), axis=1))
    lo, hi = strip.min(), strip.max()
    quant = [np.clip(np.round((v[:, :w] - lo) / (hi - lo) * 255), 0, 255).astype(np.uint8)
             for v in (strip, moved)]
    return _Case(quant[0], quant[1], np.full((h, w), shift),
                 f"a {shift:g} px shift of band-limited noise (sigma {sigma:.1f} px), {w} x {h}")


def _planar(*, integer: bool = False) -> st.SearchStrategy[_Case]:
    def case(p) -> _Case:
        kind = "fronto-parallel integer" if integer else "slanted"
        pieces = int(p.labels.max()) + 1
        return _Case(p.left, p.right, p.disparity,
                     f"{pieces} {kind} planar band(s), disparity {p.disparity.min():.1f}-"
                     f"{p.disparity.max():.1f} px, {p.left.shape[1]} x {p.left.shape[0]}",
                     (p.labels,))

    strat = piecewise_planar_pairs(max_disparity=12.0, max_pieces=3, min_side=48, max_side=72,
                                   integer=integer)
    if integer:  # the mirror check needs room for both border strips
        strat = piecewise_planar_pairs(max_disparity=12.0, max_pieces=3, min_side=64, max_side=80,
                                       integer=True)
    return strat.map(case)


def _cropped() -> st.SearchStrategy[_Case]:
    return st.tuples(_planar(), st.integers(1, 6), st.integers(1, 6)).map(
        lambda t: _Case(t[0].left, t[0].right, t[0].truth, t[0].what, (t[0].extra[0], t[1], t[2])))


def _photometric(kind: str) -> st.SearchStrategy[_Case]:
    """Low-contrast shifted pairs (contrast ``c``: ``128 + c (v - 128)``) with the right view
    changed: by a gain and bias (no clipping), or by a monotone grey map."""

    def low(c: _Case, contrast: float) -> tuple[np.ndarray, np.ndarray]:
        return tuple(128.0 + contrast * (v.astype(np.float64) - 128.0) for v in (c.left, c.right))

    def gain_bias(t) -> _Case:
        c, contrast, gain, bias = t
        left, right = low(c, contrast)
        right = np.clip(np.round(128.0 + gain * (right - 128.0) + bias), 0, 255)
        return _Case(np.round(left).astype(np.uint8), right.astype(np.uint8), c.truth,
                     f"{c.what}, contrast {contrast:.2f}, right view x {gain:.2f} {bias:+.0f}")

    def grey_map(t) -> _Case:
        c, contrast, lut = t
        left, right = (np.round(v).astype(np.uint8) for v in low(c, contrast))
        lut8 = np.floor(lut * 255.0 / lut[-1]).astype(np.uint8)
        return _Case(left, lut8[right], c.truth,
                     f"{c.what}, contrast {contrast:.2f}, a monotone grey map on the right")

    shifts, contrast = _shifts(smooth=(0.5, 1.5)), st.floats(0.15, 0.4)
    if kind == "gain_bias":
        return st.tuples(shifts, contrast, st.floats(0.5, 2.0), st.floats(-40.0, 40.0)).map(gain_bias)
    return st.tuples(shifts, contrast, monotone_maps()).map(grey_map)


def _contract_images() -> st.SearchStrategy[_Case]:
    def case(img: np.ndarray) -> _Case:
        levels = len(np.unique(img))
        return _Case(img, img[:, ::-1].copy(), None,
                     f"a {img.shape[1]} x {img.shape[0]} image with {levels} grey level(s)")

    return st.sampled_from([1, 2, 256]).flatmap(
        lambda lv: grey_images(min_side=MAX_DISPARITY + 8, max_side=48, levels=lv)).map(case)


def _identical() -> st.SearchStrategy[_Case]:
    return textured_images(min_side=48, max_side=64).map(
        lambda img: _Case(img, img, None, f"noise, {img.shape[1]} x {img.shape[0]}"))


# --------------------------------------------------------------------------- the battery
@dataclass(frozen=True)
class Property:
    """One property: a name, whether a matcher must pass it, inputs and the check of one input."""

    name: str
    required: bool
    strategy: Callable[[], st.SearchStrategy]
    check: Callable[[_Caller, _Case], _Outcome]


#: The battery, in report order.
PROPERTIES: tuple[Property, ...] = (
    Property("output_shape_dtype", True, _contract_images, _check_contract),
    Property("invalid_marking", True, _shifts, _check_invalid_marking),
    Property("integer_shift", True, _shifts, _accuracy(0.5, 0.10)),
    Property("subpixel_shift", True, _subpixel_shifts, _accuracy(1.0, 0.10)),
    Property("planar_warp", True, _planar, _accuracy(1.0, 0.15, " (away from band edges)")),
    Property("identical_views_zero", True, _identical, _check_identical),
    Property("mirror_symmetry", True, lambda: _planar(integer=True), _check_mirror),
    Property("translation_equivariance", True, _cropped, _check_translation),
    Property("left_border", True, _shifts, _check_border),
    Property("gain_bias_robustness", False, lambda: _photometric("gain_bias"), _accuracy(1.0, 0.10)),
    Property("monotone_grey_map_robustness", False, lambda: _photometric("map"),
             _accuracy(1.0, 0.10)),
)


def _evaluate(prop: Property, call: _Caller, case: _Case) -> _Outcome:
    try:
        return prop.check(call, case)
    except _MatcherFault as exc:
        return _Outcome(False, np.inf, f"{exc} on {case.what}", _images(case, case.truth, None))


class _Falsified(Exception):
    pass


def _run_property(prop: Property, call: _Caller, cfg: dict) -> tuple[_Outcome, int, bool]:
    """``(worst or shrunk outcome, examples tried, passed)``; never raises for the matcher's sake."""
    seen: dict[str, _Outcome] = {}
    state = {"failed_at": None}

    def test(case: _Case) -> None:
        key = case.key()
        if key not in seen:
            if state["failed_at"] is not None and call.calls - state["failed_at"] > cfg["shrink_calls"]:
                return  # shrink budget spent: unseen candidates count as passing
            seen[key] = _evaluate(prop, call, case)
            if not seen[key].passed and state["failed_at"] is None:
                state["failed_at"] = call.calls
        if not seen[key].passed:
            raise _Falsified(key)

    run = settings(max_examples=cfg["examples"], derandomize=True, database=None, deadline=None,
                   print_blob=False, verbosity=Verbosity.quiet, report_multiple_bugs=False,
                   phases=(Phase.generate, Phase.shrink),
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                          HealthCheck.filter_too_much,
                                          HealthCheck.large_base_example])(
        given(prop.strategy())(test))
    try:
        run()
    except _Falsified as exc:
        return seen[exc.args[0]], len(seen), False
    worst = max(seen.values(), key=lambda o: o.badness)
    return worst, len(seen), True


def _save_counterexample(folder: Path, images: dict[str, np.ndarray], rel: Path) -> list[str]:
    from synth.write.preview import colorize_disparity

    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for label in ("left", "right", "expected", "answer"):
        if label not in images:
            continue
        img = images[label]
        if img.dtype != np.uint8:
            img = colorize_disparity(img, vmin=0.0, vmax=float(MAX_DISPARITY))
        atomic_write_bytes(folder / f"{label}.png", encode_png(np.ascontiguousarray(img)))
        paths.append((rel / f"{label}.png").as_posix())
    return paths


def run_battery(matcher: Callable[..., np.ndarray], out_dir: Path, *, suite: str = "quick",
                name: str = "matcher") -> list[dict]:
    """Run the property battery on ``matcher``; write ``out_dir/properties.json`` atomically.

    Parameters
    ----------
    matcher : callable
        ``matcher(left, right, *, max_disparity) -> (H, W) array`` with (H, W, 3) uint8 RGB views;
        ``inf``/NaN = no estimate. Anything it raises is a failure of the property, recorded.
    out_dir : Path
        Folder (created if needed) for ``properties.json`` and ``properties/<name>/*.png``.
    suite : {"quick", "full"}
        Examples per property (:data:`SUITES`); ``quick`` takes a few seconds for CT-9.
    name : str
        Label of the matcher in ``properties.json``.

    Returns
    -------
    list of dict
        One entry per property: ``name``, ``passed``, ``required``, ``explanation`` (one line with
        the measured figure and the threshold), ``counterexample`` (PNG paths relative to
        ``out_dir``, or None), ``examples`` (distinct inputs tried).
    """
    if suite not in SUITES:
        raise ParameterError(f"suite: expected one of {sorted(SUITES)}, got {suite!r}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    call = _Caller(matcher)
    entries = []
    for prop in PROPERTIES:
        outcome, examples, passed = _run_property(prop, call, SUITES[suite])
        folder = out_dir / "properties" / prop.name
        shutil.rmtree(folder, ignore_errors=True)
        counterexample = None
        if passed:
            explanation = f"worst of {examples}: {outcome.text}"
        else:
            explanation = outcome.text
            counterexample = _save_counterexample(folder, outcome.images,
                                                  Path("properties") / prop.name)
        entries.append({"name": prop.name, "passed": passed, "required": prop.required,
                        "explanation": explanation, "counterexample": counterexample,
                        "examples": examples})
    doc = {"matcher": name, "suite": suite, "properties": entries}
    atomic_write_bytes(out_dir / "properties.json",
                       (json.dumps(doc, indent=1, ensure_ascii=False) + "\n").encode())
    return entries
