"""Dataset configuration parsing: examples, distributions, errors with file:line, hashing."""

from __future__ import annotations

import numpy as np
import pytest

from synth.dataset.config.parse import (
    EXAMPLES,
    SCHEMA,
    ConfigError,
    DatasetConfig,
    Dist,
    config_from_dict,
    load_config,
    loads_config,
)


@pytest.mark.parametrize("name", EXAMPLES)
def test_shipped_examples_parse_and_round_trip(name):
    cfg = load_config(name)
    assert cfg.name == name
    want = {"middlebury-like": (450, 375),  # Middlebury 2006 third size
            "floating": (960, 540), "dense": (960, 540),
            "outdoor": (960, 540), "mix": (960, 540)}.get(name, (640, 480))
    assert (cfg.rig.width, cfg.rig.height) == want
    assert config_from_dict(cfg.to_dict()) == cfg
    assert config_from_dict(cfg.to_dict()).hash() == cfg.hash()


def test_defaults_fill_every_non_optional_key():
    cfg = loads_config("")
    assert cfg.seed == 0 and cfg.count == 10 and cfg.preview is False
    assert set(cfg.scene) == {k for k, s in SCHEMA["scene"].items() if not s.optional}
    assert cfg.photometric["gain"] == Dist("fixed", (1.0,))
    assert cfg.rig.fx == 600.0 and cfg.rig.cx == 319.5


def test_distributions_are_parsed():
    cfg = loads_config(
        "[scene]\n"
        'base = {choice = ["boxes", "flying"]}\n'
        "frequency_px = {loguniform = [0.05, 0.2]}\n"
        "occluders = {uniform = [1, 3]}\n"
        "[photometric]\n"
        "jpeg_quality = {choice = [0, 90]}\n"
    )
    assert cfg.scene["base"] == Dist("choice", ("boxes", "flying"))
    assert cfg.scene["frequency_px"] == Dist("loguniform", (0.05, 0.2))
    assert cfg.scene["occluders"] == Dist("uniform", (1, 3), integer=True)
    assert cfg.photometric["jpeg_quality"] == Dist("choice", (0, 90))


def test_integer_uniform_includes_both_ends():
    rng = np.random.default_rng(0)
    draws = {Dist("uniform", (1, 3), integer=True).sample(rng) for _ in range(200)}
    assert draws == {1, 2, 3}
    logs = [Dist("loguniform", (2, 5), integer=True).sample(rng) for _ in range(400)]
    assert set(logs) == {2, 3, 4, 5} and all(isinstance(v, int) for v in logs)


def test_fixed_values_consume_no_randomness():
    rng = np.random.default_rng(5)
    before = rng.bit_generator.state
    assert Dist("fixed", (0.3,)).sample(rng) == 0.3
    assert rng.bit_generator.state == before


def test_hash_ignores_count_but_not_anything_else():
    a = loads_config("count = 5\nseed = 1")
    assert a.hash() == loads_config("count = 500\nseed = 1").hash()
    assert a.hash() != loads_config("count = 5\nseed = 2").hash()
    assert a.hash() != loads_config("seed = 1\n[photometric]\nnoise_sigma = 1.0").hash()


TEXT = """\
name = "t"
seed = 1

[rig]
width = 64

[scene]
base = "boxes"
occluders = 2
"""


@pytest.mark.parametrize(
    ("edit", "line", "needles"),
    [
        (("occluders = 2", "ocluders = 2"), 9, ["unknown key 'ocluders'", "occluders"]),
        (("width = 64", "width = 4"), 5, ["rig.width: expected an integer in [8, 8192], got 4"]),
        (('base = "boxes"', 'base = "box"'), 8,
         ["scene.base: expected one of ['fronto_plane'", "got 'box'", "did you mean 'boxes'?"]),
        (("occluders = 2", "occluders = {uniform = [3, 1]}"), 9, ["a <= b"]),
        (("occluders = 2", "occluders = {normal = [0, 1]}"), 9, ["{uniform=[a,b]}"]),
        (("occluders = 2", "occluders = [1, 2]"), 9, ["{choice = [1, 2]}"]),
        (("seed = 1", "seed = {uniform = [1, 2]}"), 2, ["takes a fixed value"]),
        (("[rig]", "[rigs]"), 4, ["unknown key 'rigs'", "[rig]"]),
        (("occluders = 2", "occluders = 2.5"), 9,
         ["scene.occluders: expected an integer in [0, 256], got float 2.5"]),
        (("occluders = 2", "occluders = {choice = [1, 'a']}"), 9,
         ["scene.occluders.choice[1]: expected an integer", "got str 'a'"]),
        (("seed = 1", "seed = true"), 2, ["seed: expected an integer", "got bool True"]),
    ],
)
def test_errors_name_file_line_and_allowed_values(edit, line, needles):
    text = TEXT.replace(*edit)
    with pytest.raises(ConfigError) as info:
        loads_config(text, source="my.toml")
    message = str(info.value)
    assert message.startswith(f"my.toml:{line}:"), message
    for needle in needles:
        assert needle in message, message


def test_photometric_range_error_gives_line_and_interval(tmp_path):
    path = tmp_path / "cfg.toml"
    path.write_text("count = 3\n\n[photometric]\n# comment\ngain = {uniform = [0.5, 9.0]}\n")
    with pytest.raises(ConfigError, match=r"cfg\.toml:5: photometric\.gain\.uniform\[1\]: "
                                          r"expected .*\(0\.0, 4\.0\], got 9\.0"):
        load_config(path)


def test_edge_density_and_frequency_exclude_each_other():
    with pytest.raises(ConfigError, match=r"<string>:3: .*exclude each other"):
        loads_config("[scene]\nfrequency_px = 0.1\nedge_density = 0.1\n")


def test_invalid_toml_and_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="invalid TOML"):
        loads_config("count = = 3", source="bad.toml")
    with pytest.raises(FileNotFoundError, match="planes"):
        load_config(tmp_path / "missing.toml")
    with pytest.raises(TypeError, match="DatasetConfig"):
        load_config(3)  # type: ignore[arg-type]


def test_a_utf8_byte_order_mark_is_dropped_and_lines_stay_those_of_the_file(tmp_path):
    text = 'name = "bom"\ncount = 3\n\n[rig]\nwidth = 32\n'
    plain, bom = tmp_path / "plain.toml", tmp_path / "bom.toml"
    plain.write_text(text)
    bom.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert load_config(bom).to_dict() == load_config(plain).to_dict()
    bom.write_bytes(b"\xef\xbb\xbf" + text.replace("32", "4.5").encode())
    with pytest.raises(ConfigError, match=r"bom\.toml:5: rig\.width: expected an integer"):
        load_config(bom)


def test_near_far_checked_at_the_far_key():
    with pytest.raises(ConfigError, match=r"<string>:3: rig\.far: expected near < far, "
                                          r"got near = 5\.0, far = 2\.0"):
        loads_config("[rig]\nnear = 5.0\nfar = 2.0\n")


def test_load_config_passes_parsed_configs_through():
    cfg = loads_config("count = 2")
    assert load_config(cfg) is cfg
    assert isinstance(cfg, DatasetConfig)


# --------------------------------------------------------------------------- line numbers
def test_line_after_a_multiline_string_that_mentions_a_table():
    # the [scene] inside the string is no table header: the key is on line 6, not 3
    text = 'name = """\n[scene]\noccluders = 1\n"""\n[scene]\noccluders = 999\n'
    with pytest.raises(ConfigError, match=r"^my\.toml:6: scene\.occluders: expected an integer"):
        loads_config(text, source="my.toml")
    literal = text.replace('"""', "'''")
    with pytest.raises(ConfigError, match=r"^my\.toml:6: scene\.occluders"):
        loads_config(literal, source="my.toml")


def test_line_inside_an_inline_table():
    text = 'name = "t"\n\nscene = { base = "boxes", occluders = -1 }\n'
    with pytest.raises(ConfigError, match=r"^my\.toml:3: scene\.occluders: expected an integer "
                                          r"in \[0, 256\].*got -1"):
        loads_config(text, source="my.toml")


def test_line_of_a_dotted_key_and_of_an_unknown_key_in_an_inline_table():
    with pytest.raises(ConfigError, match=r"^my\.toml:2: photometric\.gain: .*got 9\.0"):
        loads_config("seed = 1\nphotometric.gain = 9.0\n", source="my.toml")
    with pytest.raises(ConfigError, match=r"^my\.toml:2: unknown key 'gian' in \[photometric\]"
                                          r".*did you mean 'gain'\?"):
        loads_config("seed = 1\nphotometric = {\n  gian = 1.0 }\n".replace("{\n  ", "{ "),
                     source="my.toml")
