"""matcher.learned: the network, the cost volume's conventions, model files and their errors,
and ``learned:MODEL.pt`` as a MATCHER string."""

from __future__ import annotations

import importlib.util
import os
import re

import numpy as np
import pytest

if importlib.util.find_spec("torch") is None:  # the extra 'learn'
    if os.environ.get("STEREOFORGE_REQUIRE_TORCH", "") not in ("", "0"):
        raise RuntimeError("torch is not installed and STEREOFORGE_REQUIRE_TORCH=1 forbids skipping")
    pytest.skip("torch is not installed (pip install 'stereoforge[learn]')", allow_module_level=True)

import torch  # noqa: E402

from matcher import resolve_matcher  # noqa: E402
from matcher.adapters import MatcherError  # noqa: E402
from matcher.cost import COST_SENTINEL, aggregate_cost  # noqa: E402
from matcher.learned import (  # noqa: E402
    COST_SCALE,
    Architecture,
    ModelError,
    PatchNet,
    features,
    learned_cost,
    load_model,
    match_learned,
    save_model,
)
from matcher.learned.model import LearnedModel  # noqa: E402
from matcher.select import winner_takes_all  # noqa: E402


def _model(seed: int = 0, arch: Architecture = Architecture(channels=8, layers=3)) -> LearnedModel:
    torch.manual_seed(seed)
    return LearnedModel(net=PatchNet(arch).eval())


def _noise_pair(shift: int, shape=(40, 72), seed=1) -> tuple[np.ndarray, np.ndarray]:
    """Right view = the left one moved ``shift`` px to the left (a left pixel x matches x - shift)."""
    rng = np.random.default_rng(seed)
    wide = rng.integers(0, 256, (shape[0], shape[1] + shift), dtype=np.uint8)
    return wide[:, :shape[1]].copy(), wide[:, shift:].copy()


def test_features_are_unit_vectors_of_the_whole_view():
    m = _model()
    img = np.random.default_rng(0).integers(0, 256, (30, 50, 3), dtype=np.uint8)
    f = features(m, img)
    assert f.shape == (30, 8, 50) and f.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(f, axis=1), 1.0, rtol=1e-5)


def test_features_of_strips_equal_one_pass(monkeypatch):
    m = _model()
    img = np.random.default_rng(2).integers(0, 256, (37, 29), dtype=np.uint8)
    whole = features(m, img)
    monkeypatch.setattr("matcher.learned.cost.STRIP_PIXELS", 29 * 5)  # strips of 5 rows
    np.testing.assert_allclose(features(m, img), whole, atol=2e-6)


def test_cost_volume_follows_the_census_conventions():
    m = _model()
    left, right = _noise_pair(3)
    cost = learned_cost(m, left, right, max_disparity=6)
    assert cost.shape == (40, 6, 72) and cost.dtype == np.uint16
    for d in range(6):
        assert (cost[:, d, :d] == COST_SENTINEL).all()
        assert (cost[:, d, d:] <= 2 * COST_SCALE).all()
    # the true match has the same features away from the borders (up to the views' own
    # standardisation): a cost of a few units of 16384, the smallest of the pixel's candidates
    inner = cost[8:-8, :, 12:-8]
    assert inner[:, 3].max() <= 8 and (inner.argmin(axis=1) == 3).all()
    assert aggregate_cost(cost, size=3).dtype == np.uint32  # census's steps take it as it is


def test_cost_is_the_quantised_cosine():
    m = _model()
    left, right = _noise_pair(2, shape=(12, 20))
    fl, fr = features(m, left), features(m, right)
    cost = learned_cost(m, left, right, max_disparity=4)
    y, x, d = 5, 11, 3
    cos = float(np.dot(fl[y, :, x], fr[y, :, x - d]))
    assert abs(int(cost[y, d, x]) - round((1 - cos) * COST_SCALE)) <= 1


@pytest.mark.parametrize("shift", [0, 4, 9])
def test_an_untrained_network_finds_an_integer_shift_of_noise(shift):
    left, right = _noise_pair(shift)
    res = match_learned(left, right, _model(), max_disparity=12, aggregate=1, subpixel=False)
    inner = res.disparity[6:-6, 12 + 6:-6]
    assert res.method == "learned" and res.window == 7 and res.ops is None
    assert (inner == shift).mean() >= 0.99


def test_match_learned_equals_the_census_steps_on_its_cost():
    m = _model()
    left, right = _noise_pair(5)
    cost = learned_cost(m, left, right, max_disparity=10)
    want = winner_takes_all(aggregate_cost(cost, size=5), lr_check=True, subpixel=True)
    got = match_learned(left, right, m, max_disparity=10, aggregate=5, lr_check=True,
                        subpixel=True).disparity
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("aggregate, lr_check", [(1, False), (5, True), (9, False)])
def test_strips_of_the_volume_give_the_whole_volumes_disparity(monkeypatch, aggregate, lr_check):
    m = _model()
    left, right = _noise_pair(4, shape=(37, 50))
    cost = learned_cost(m, left, right, max_disparity=10)
    vol = cost if aggregate == 1 else aggregate_cost(cost, size=aggregate)
    want = winner_takes_all(vol, lr_check=lr_check, subpixel=True)
    monkeypatch.setattr("matcher.learned.match.VOLUME_BYTES", 10 * 50 * 6 * (3 + aggregate))
    got = match_learned(left, right, m, max_disparity=10, aggregate=aggregate,
                        lr_check=lr_check, subpixel=True).disparity
    np.testing.assert_array_equal(got, want)


def test_rgb_and_grey_views_give_the_same_answer():
    rng = np.random.default_rng(4)
    grey = rng.integers(0, 256, (30, 60), dtype=np.uint8)
    rgb = np.repeat(grey[..., None], 3, axis=2)
    m = _model()
    a = match_learned(grey, np.roll(grey, -3, axis=1), m, max_disparity=8).disparity
    b = match_learned(rgb, np.roll(rgb, -3, axis=1), m, max_disparity=8).disparity
    np.testing.assert_array_equal(a, b)


def test_model_file_round_trip(tmp_path):
    m = _model(seed=3)
    path = save_model(tmp_path / "m.pt", m.net, {"training": {"seed": 3, "steps": 7},
                                                 "inference": {"aggregate": 7}})
    back = load_model(path)
    assert back.arch == m.arch and back.path == path
    assert back.header["architecture"] == {"name": "mccnn-fast", "channels": 8, "layers": 3,
                                           "kernel": 3, "patch": 7}
    assert back.header["training"] == {"seed": 3, "steps": 7}
    assert back.inference == {"aggregate": 7, "lr_check": False, "subpixel": True}
    assert "stereoforge_version" in back.header
    for k, v in m.net.state_dict().items():
        assert torch.equal(back.net.state_dict()[k], v)
    left, right = _noise_pair(4)
    np.testing.assert_array_equal(match_learned(left, right, back, max_disparity=8).disparity,
                                  match_learned(left, right, m, max_disparity=8,
                                                aggregate=7).disparity)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.pt"]  # no temporary file left


def _write_other(path, blob):
    torch.save(blob, path)
    return path


@pytest.mark.parametrize("case", ["truncated", "garbage", "empty", "other_dict", "architecture",
                                  "weights", "version", "directory"])
def test_bad_model_files_are_one_line_errors(tmp_path, case):
    good = save_model(tmp_path / "good.pt", _model().net, {})
    blob = torch.load(good, weights_only=True)
    bad = tmp_path / "bad.pt"
    if case == "truncated":
        bad.write_bytes(good.read_bytes()[:200])
    elif case == "garbage":
        bad.write_bytes(np.random.default_rng(0).bytes(4096))
    elif case == "empty":
        bad.write_bytes(b"")
    elif case == "other_dict":
        _write_other(bad, {"weights": torch.zeros(3)})
    elif case == "architecture":
        blob["header"]["architecture"]["name"] = "raft-stereo"
        _write_other(bad, blob)
    elif case == "weights":
        blob["header"]["architecture"]["channels"] = 16
        _write_other(bad, blob)
    elif case == "version":
        blob["format_version"] = 99
        _write_other(bad, blob)
    else:
        bad.mkdir()
    with pytest.raises(ModelError) as info:
        load_model(bad)
    text = str(info.value)
    assert "\n" not in text and str(bad) in text and "stereoforge train" in text
    expected = {"architecture": "'raft-stereo'", "weights": "do not fit", "version": "99",
                "directory": "is a folder, not a regular file", "other_dict": "not a stereoforge-learned-matcher"}
    assert expected.get(case, "not a readable model file") in text


def test_learned_matcher_string(tmp_path):
    path = save_model(tmp_path / "net.pt", _model().net, {})
    m = resolve_matcher(f"learned:{path}")
    assert m.kind == "learned" and m.name == "learned:net"
    left, right = _noise_pair(4)
    grey = m(left, right, max_disparity=8)
    rgb = m(np.repeat(left[..., None], 3, 2), np.repeat(right[..., None], 3, 2), max_disparity=8)
    assert grey.dtype == np.float32 and grey.shape == left.shape
    np.testing.assert_array_equal(grey, rgb)
    outcome = m.run(left, right[:, :10], max_disparity=8)  # failures are outcomes, not raises
    assert outcome.disparity is None and outcome.error.startswith("crashed: ")


def test_learned_matcher_string_errors(tmp_path):
    with pytest.raises(MatcherError, match="does not exist"):
        resolve_matcher(f"learned:{tmp_path}/missing.pt")
    (tmp_path / "bad.pt").write_bytes(b"not a model")
    with pytest.raises(MatcherError, match="not a readable model file"):
        resolve_matcher(f"learned:{tmp_path}/bad.pt")
    with pytest.raises(MatcherError, match="learned:MODEL.pt"):
        resolve_matcher("learned:")


# ------------------------------------------------------------------ the torch pipeline
def _both_paths(left, right, m, **kw):
    a = match_learned(left, right, m, pipeline="numba", **kw).disparity
    b = match_learned(left, right, m, pipeline="torch", **kw).disparity
    return a, b


def _assert_same_disparity(a, b):
    """Integer disparities and the invalid mask exactly, sub-pixel values within 1e-4 px."""
    np.testing.assert_array_equal(np.isinf(a), np.isinf(b))
    ok = np.isfinite(a)
    np.testing.assert_array_equal(np.floor(a[ok]) == a[ok], np.floor(b[ok]) == b[ok])
    np.testing.assert_allclose(b[ok], a[ok], rtol=0, atol=1e-4)


@pytest.mark.parametrize("shape, n_disp", [((40, 72), 16), ((23, 41), 40), ((9, 12), 11)])
@pytest.mark.parametrize("aggregate", [1, 3, 7])
@pytest.mark.parametrize("lr_check", [False, True])
def test_torch_pipeline_equals_the_numba_path(shape, n_disp, aggregate, lr_check):
    m = _model(seed=5)
    left, right = _noise_pair(3, shape=shape, seed=7)
    right = np.clip(right.astype(int) + np.random.default_rng(8).integers(-20, 21, shape), 0,
                    255).astype(np.uint8)  # noise: ties, LR failures and parabolas both ways
    for subpixel in (False, True):
        a, b = _both_paths(left, right, m, max_disparity=n_disp, aggregate=aggregate,
                           lr_check=lr_check, subpixel=subpixel, lr_tolerance=0)
        _assert_same_disparity(a, b)
        if not subpixel:
            np.testing.assert_array_equal(a, b)  # integer disparities: exactly
    if lr_check:
        assert np.isinf(a).any()  # the check did reject something here


@pytest.mark.parametrize("aggregate, lr_check", [(1, True), (5, False), (9, True)])
def test_chunks_of_the_torch_volume_give_the_whole_volumes_disparity(monkeypatch, aggregate,
                                                                     lr_check):
    from matcher.learned import volume

    m = _model()
    left, right = _noise_pair(4, shape=(37, 50))
    want = match_learned(left, right, m, max_disparity=10, aggregate=aggregate,
                         lr_check=lr_check, pipeline="numba").disparity
    # a chunk of 2 rows besides the box's halo: many chunks, the image's edges inside chunks
    monkeypatch.setitem(volume.CHUNK_BYTES, "cpu",
                        volume.BYTES_PER_ENTRY * 10 * 50 * (2 + aggregate - 1))
    got = match_learned(left, right, m, max_disparity=10, aggregate=aggregate,
                        lr_check=lr_check, pipeline="torch").disparity
    np.testing.assert_array_equal(got, want)


def test_torch_pipeline_on_a_trained_sized_network():
    """32 maps x 4 layers (the training default): long float32 sums, costs across the range."""
    m = _model(seed=2, arch=Architecture())
    left, right = _noise_pair(6, shape=(30, 64), seed=3)
    a, b = _both_paths(left, right, m, max_disparity=24, aggregate=5, lr_check=True,
                       subpixel=True)
    _assert_same_disparity(a, b)


def test_pipeline_auto_is_numba_on_the_cpu_and_bad_names_are_errors(monkeypatch):
    from stereoforge.errors import ParameterError

    m = _model()
    left, right = _noise_pair(2)
    called = []
    monkeypatch.setattr("matcher.learned.match.volume_disparity",
                        lambda *a, **k: called.append(1))
    match_learned(left, right, m, max_disparity=8)  # the CPU default: numba, not torch
    assert called == []
    with pytest.raises(ParameterError, match="pipeline"):
        match_learned(left, right, m, max_disparity=8, pipeline="gpu")


# ------------------------------------------------------------------ the device of a MATCHER
def _no_gpu(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 0)


def test_learned_matcher_string_names_its_device(tmp_path, monkeypatch):
    path = save_model(tmp_path / "net.pt", _model().net, {})
    left, right = _noise_pair(4)
    want = resolve_matcher(f"learned:{path}?device=cpu")(left, right, max_disparity=8)
    _no_gpu(monkeypatch)
    monkeypatch.delenv("STEREOFORGE_DEVICE", raising=False)
    plain = resolve_matcher(f"learned:{path}")
    assert plain._target[1] == "cpu" and plain.name == "learned:net"  # auto without a GPU
    np.testing.assert_array_equal(plain(left, right, max_disparity=8), want)
    monkeypatch.setenv("STEREOFORGE_DEVICE", "cuda")  # the environment names a device ...
    with pytest.raises(MatcherError, match="STEREOFORGE_DEVICE: 'cuda' but torch sees no CUDA"):
        resolve_matcher(f"learned:{path}")
    m = resolve_matcher(f"learned:{path}?device=cpu")  # ... the string wins
    assert m._target[1] == "cpu" and m.spec == f"learned:{path}?device=cpu"
    monkeypatch.setenv("STEREOFORGE_DEVICE", "CPU")
    assert resolve_matcher(f"learned:{path}")._target[1] == "cpu"


@pytest.mark.parametrize("query, words", [
    ("device=cuda", "'cuda' but torch sees no CUDA GPU here; use cpu"),
    ("device=cuda:1", "'cuda:1' but torch sees no CUDA GPU"),
    ("device=tpu", "expected auto, cpu, cuda or cuda:N, got 'tpu'"),
    ("device=", "takes device=auto, cpu, cuda or cuda:N, got 'device='"),
    ("aggregate=5", "takes device=auto"),
])
def test_bad_devices_fail_when_the_string_is_resolved(tmp_path, monkeypatch, query, words):
    _no_gpu(monkeypatch)
    path = save_model(tmp_path / "net.pt", _model().net, {})
    with pytest.raises(MatcherError) as info:
        resolve_matcher(f"learned:{path}?{query}")
    assert words in str(info.value) and "\n" not in str(info.value)


def test_cli_bad_device_is_one_error_line_before_any_work(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from matcher.io import encode_png
    from synth.cli import main

    _no_gpu(monkeypatch)
    path = save_model(tmp_path / "net.pt", _model().net, {})
    left, right = _noise_pair(3)
    (tmp_path / "l.png").write_bytes(encode_png(left))
    (tmp_path / "r.png").write_bytes(encode_png(right))
    out = tmp_path / "d.pfm"
    base = ["match", str(tmp_path / "l.png"), str(tmp_path / "r.png"), "--max-disp", "8",
            "--out", str(out), "--matcher"]
    for spec, env in ((f"learned:{path}?device=cuda", {}), (f"learned:{path}?device=metal", {}),
                      (f"learned:{path}", {"STEREOFORGE_DEVICE": "cuda:0"})):
        r = CliRunner().invoke(main, [*base, spec], env=env)
        lines = r.output.strip().splitlines()
        assert r.exit_code == 2 and len(lines) == 1 and lines[0].startswith("Error: "), r.output
        assert not out.exists()
    r = CliRunner().invoke(main, [*base, f"learned:{path}?device=cpu"],
                           env={"STEREOFORGE_DEVICE": "cuda"})
    assert r.exit_code == 0, r.output
    assert r.output.startswith("learned:net D=8:") and out.is_file()


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_weights_that_are_not_finite_are_refused_on_save_and_on_load(tmp_path, value):
    good = save_model(tmp_path / "good.pt", _model().net, {})
    blob = torch.load(good, weights_only=True)
    blob["state_dict"]["convs.1.bias"][2] = value  # one number of a diverged training
    bad = _write_other(tmp_path / "bad.pt", blob)
    with pytest.raises(ModelError, match=r"the weights convs\.1\.bias are not finite") as info:
        load_model(bad)
    assert str(bad) in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(MatcherError, match="not finite"):
        resolve_matcher(f"learned:{bad}")
    net = _model().net
    with torch.no_grad():
        net.convs[0].weight[0, 0, 1, 1] = value
    with pytest.raises(ValueError, match="hold NaN or inf"):
        save_model(tmp_path / "diverged.pt", net, {})
    assert not (tmp_path / "diverged.pt").exists()


@pytest.mark.parametrize("channels, layers, words", [
    (10**9, 3, "channels: expected an integer 1..1024, got 1000000000"),
    (8, 10**6, "layers: expected an integer 1..32"),
    (1024, 32, "1024 channels x 32 layers has 292,594,688 weights; at most 33,554,432"),
    (True, 3, "channels: expected an integer"),
    ("8", 3, "channels: expected an integer"),
])
def test_header_sizes_are_bounded_before_anything_is_allocated(tmp_path, monkeypatch, channels,
                                                                layers, words):
    blob = torch.load(save_model(tmp_path / "good.pt", _model().net, {}), weights_only=True)
    blob["header"]["architecture"].update(channels=channels, layers=layers)
    bad = _write_other(tmp_path / "bad.pt", blob)

    def no_network(arch):  # a network the header sized would be allocated here
        raise AssertionError(f"a network of {arch} was built from an unchecked header")

    monkeypatch.setattr(Architecture, "network", no_network)
    with pytest.raises(ModelError) as info:
        load_model(bad)
    assert words in str(info.value) and str(bad) in str(info.value)


def test_one_architecture_limit_for_train_and_load_model(tmp_path):
    from matcher.learned.network import MAX_CHANNELS, MAX_LAYERS, check_architecture

    top = check_architecture(MAX_CHANNELS, 4)  # the largest width train accepts ...
    torch.manual_seed(0)
    path = save_model(tmp_path / "wide.pt", PatchNet(top), {})
    assert load_model(path).arch == top  # ... load_model reads
    blob = torch.load(path, weights_only=True)
    blob["header"]["architecture"]["channels"] = MAX_CHANNELS + 1
    with pytest.raises(ModelError, match=f"expected an integer 1..{MAX_CHANNELS}, got 1025"):
        load_model(_write_other(tmp_path / "wider.pt", blob))
    with pytest.raises(ValueError, match=f"layers: expected an integer 1..{MAX_LAYERS}"):
        check_architecture(8, MAX_LAYERS + 1)


@pytest.mark.parametrize("inference, words", [
    ({"aggregate": 4}, "inference.aggregate: expected 1 (none) or an odd box side 3..511, got 4"),
    ({"aggregate": 513}, "inference.aggregate: expected an integer in [1, 511], got 513"),
    ({"aggregate": 5.0}, "inference.aggregate: expected an integer"),
    ({"lr_check": "yes"}, "inference.lr_check: expected True or False"),
    ({"subpixel": 1}, "inference.subpixel: expected True or False"),
])
def test_header_inference_steps_are_checked_on_save_and_on_load(tmp_path, inference, words):
    with pytest.raises(ValueError, match=re.escape(words)):
        save_model(tmp_path / "m.pt", _model().net, {"inference": inference})
    blob = torch.load(save_model(tmp_path / "good.pt", _model().net, {}), weights_only=True)
    blob["header"]["inference"].update(inference)
    bad = _write_other(tmp_path / "bad.pt", blob)
    with pytest.raises(ModelError, match=re.escape(words)):
        load_model(bad)
    with pytest.raises(MatcherError, match=re.escape(words)):  # refused when named, not per pair
        resolve_matcher(f"learned:{bad}")


def test_the_scores_of_interpolated_right_features_are_cosines():
    from matcher.learned import pair_scores

    # right features e1 at column 0 and e2 at column 1: halfway between, the interpolated
    # feature (e1 + e2) / 2 is re-normalised, so its cosine with e1 is 1/sqrt(2), not 1/2
    fr = torch.zeros(4, 1, 2)
    fr[0, 0, 0], fr[1, 0, 1] = 1.0, 1.0
    fl = torch.zeros(4, 1, 1)
    fl[0, 0, 0] = 1.0
    idx = torch.zeros(1, dtype=torch.int64)
    s_pos, s_neg = pair_scores(fl, fr, idx, idx, torch.tensor([0.5]), torch.tensor([1.0]))
    assert float(s_pos) == pytest.approx(2 ** -0.5, abs=1e-6)
    assert float(s_neg) == pytest.approx(0.0, abs=1e-6)
    s_quarter, _ = pair_scores(fl, fr, idx, idx, torch.tensor([0.25]), torch.tensor([0.0]))
    assert float(s_quarter) == pytest.approx(0.75 / (0.75**2 + 0.25**2) ** 0.5, abs=1e-6)


# ------------------------------------------------------------------ the Triton cost kernel
@pytest.fixture
def triton_on_the_cpu(monkeypatch):
    """The Triton cost kernel in Triton's interpreter (numpy on the CPU), used by the torch
    pipeline as it is on a CUDA device."""
    if importlib.util.find_spec("triton") is None:
        pytest.skip("triton is not installed (torch's CUDA builds for Linux bring it)")
    import sys

    from matcher.learned import volume

    monkeypatch.setenv("TRITON_INTERPRET", "1")  # read when the kernel is decorated
    sys.modules.pop("matcher.learned._triton_cost", None)
    kernel = importlib.import_module("matcher.learned._triton_cost")
    monkeypatch.setattr(volume, "_cost_for", lambda device: kernel.cost)
    yield kernel
    sys.modules.pop("matcher.learned._triton_cost", None)  # not the interpreted one for others


def test_the_triton_cost_kernel_gives_the_torch_costs_bit_for_bit(triton_on_the_cpu):
    """Costs across the range and tiles cut by the image's edges (the blocks are 32 x 64).

    The interpreter rounds every float32 operation on its own (numpy), so this checks the
    kernel's operations and their order; that the GPU compiles them without fused
    multiply-adds (``enable_fp_fusion=False``) is checked on a GPU by the test below."""
    from matcher.learned import volume

    g = torch.Generator().manual_seed(0)
    for h, c, w, n_disp in [(2, 32, 70, 37), (3, 8, 131, 5)]:
        fl = torch.nn.functional.normalize(torch.randn(h, c, w, generator=g), dim=1)
        fr = torch.nn.functional.normalize(torch.randn(h, c, w, generator=g), dim=1)
        fr[:, :, ::7] = fl[:, :, ::7]  # equal features: costs at 0 too
        want = volume._cost(fl, fr, n_disp, float(COST_SCALE))
        got = triton_on_the_cpu.cost(fl, fr, n_disp, float(COST_SCALE))
        assert got.dtype == want.dtype and torch.equal(got, want)
        assert (want == 0).any() and (want == 65535).any()


@pytest.mark.parametrize("aggregate, lr_check", [(1, True), (5, True)])
def test_the_pipeline_with_the_triton_kernel_equals_the_numba_path(triton_on_the_cpu, aggregate,
                                                                   lr_check):
    m = _model(seed=2, arch=Architecture())  # 32 maps: the training default
    left, right = _noise_pair(5, shape=(14, 70), seed=3)
    a, b = _both_paths(left, right, m, max_disparity=20, aggregate=aggregate, lr_check=lr_check,
                       subpixel=True)
    _assert_same_disparity(a, b)


@pytest.mark.skipif(not torch.cuda.is_available(),
                    reason="no CUDA GPU here: the compiled kernel is checked where there is one")
def test_the_triton_cost_kernel_on_a_gpu_gives_the_cpu_costs():
    if importlib.util.find_spec("triton") is None:
        pytest.skip("triton is not installed (torch's CUDA builds for Linux bring it)")
    from matcher.learned import volume
    from matcher.learned._triton_cost import cost

    g = torch.Generator().manual_seed(1)
    fl = torch.nn.functional.normalize(torch.randn(9, 32, 301, generator=g), dim=1)
    fr = torch.nn.functional.normalize(torch.randn(9, 32, 301, generator=g), dim=1)
    want = volume._cost(fl, fr, 77, float(COST_SCALE))  # on the CPU: the numba path's numbers
    got = cost(fl.cuda(), fr.cuda(), 77, float(COST_SCALE)).cpu()
    assert torch.equal(got, want)
    assert volume._cost_for(torch.device("cuda")) is cost


@pytest.mark.parametrize("count", [1, 2, 3])
def test_cuda_n_is_refused_exactly_past_the_last_gpu(monkeypatch, count):
    """A faked device count: cuda:0 .. cuda:count-1 are taken, cuda:count is not (the bound
    off by one in either direction fails this)."""
    from matcher.learned.device import check_device
    from stereoforge.errors import ParameterError

    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: count)
    for n in range(count):
        assert check_device(f"cuda:{n}", "--device") == f"cuda:{n}"
    assert check_device("cuda", "--device") == "cuda"
    with pytest.raises(ParameterError, match=rf"torch sees {count} GPU\(s\) \(cuda:0 \.\. "
                                             rf"cuda:{count - 1}\)"):
        check_device(f"cuda:{count}", "--device")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    with pytest.raises(ParameterError, match="torch sees no CUDA GPU here"):
        check_device("cuda:0", "--device")
