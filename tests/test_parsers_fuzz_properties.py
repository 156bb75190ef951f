"""Fuzzing every parser: random bytes and mutated valid documents raise only the project's errors.

Each parser gets two properties: arbitrary input (bytes, or text for the text parsers), and a
valid document of its format with a few random edits (bytes deleted, inserted, replaced,
repeated; the document cut short). Whatever the input, the parser returns or raises a
:class:`stereoforge.errors.StereoforgeError` subclass naming the problem; never a ``KeyError``,
``TypeError``, ``OverflowError``, ``RecursionError``, ``cv2.error`` ...

Examples per property: ``FUZZ_FACTOR`` x the profile's ``max_examples`` (``ci``: 12 x 25 = 300,
a second or two per parser; ``thorough``: 12 x 1000 = 12,000). Each property is paired with the
hand-picked inputs that crashed a parser before (``test_known_bad_inputs``).
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from matcher.io import decode_pfm, encode_png, format_calib, parse_calib, read_calib, read_pfm
from matcher.io.png import read_disparity, read_image
from scenes import dumps_json, dumps_toml, get_preset, load_scene, loads_json, loads_toml
from stereoforge.errors import StereoforgeError
from synth.dataset.config.parse import load_config, loads_config
from synth.dataset.run import read_manifest, render_from_manifest
from synth.jobs.study.config import load_study_config, loads_study_config

FUZZ_FACTOR = 12
FUZZ = settings(max_examples=FUZZ_FACTOR * settings.default.max_examples)

_WORK = Path(tempfile.mkdtemp(prefix="stereoforge-fuzz-"))


# --------------------------------------------------------------------------- inputs
@st.composite
def mutated(draw: st.DrawFn, valid: bytes) -> bytes:
    """``valid`` with 1-4 random edits."""
    data = bytearray(valid)
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(("delete", "insert", "replace", "repeat", "truncate")))
        i = draw(st.integers(0, max(len(data) - 1, 0)))
        if op == "delete" and data:
            del data[i:i + draw(st.integers(1, 8))]
        elif op == "insert":
            data[i:i] = draw(st.binary(min_size=1, max_size=8)
                             | st.sampled_from([b"[", b"{", b"=", b"\n", b"\xff", b"-", b"9" * 30,
                                                b"inf", b"nan", b"1e400", b'"', b"[" * 2000]))
        elif op == "replace" and data:
            data[i] = draw(st.integers(0, 255))
        elif op == "repeat" and data:
            j = draw(st.integers(i, min(len(data), i + 64)))
            data[i:i] = data[i:j] * draw(st.integers(1, 4))
        else:
            del data[i:]
    return bytes(data)


def _text(data: bytes) -> str:
    return data.decode("utf-8", errors="replace")


def _file(data: bytes, name: str) -> Path:
    path = _WORK / name
    path.write_bytes(data)
    return path


def _only_ours(parse: Callable[[], object]) -> bool:
    """``parse()`` returns (False), or raises one of the project's errors (True)."""
    try:
        parse()
    except StereoforgeError:
        return True
    return False


# --------------------------------------------------------------------------- valid documents
_PFM = __import__("matcher.io", fromlist=["encode_pfm"]).encode_pfm(
    np.array([[1.0, np.inf, 2.5], [0.0, -1.0, 3.0]], np.float32))
_PNG16 = encode_png(np.array([[0, 256, 512], [1024, 7, 65535]], np.uint16))
_PNG8 = encode_png(np.array([[0, 3, 6], [9, 12, 255]], np.uint8))
_CALIB = format_calib({"cam0": np.array([[500.0, 0, 31.5], [0, 500, 23.5], [0, 0, 1]]),
                       "cam1": np.array([[500.0, 0, 31.5], [0, 500, 23.5], [0, 0, 1]]),
                       "doffs": 0, "baseline": 100.0, "width": 64, "height": 48, "ndisp": 32,
                       "vmin": 3, "vmax": 20}).encode()
_SCENE = get_preset("boxes", seed=3)
_SCENE_TOML, _SCENE_JSON = dumps_toml(_SCENE).encode(), dumps_json(_SCENE).encode()
_CONFIG_DIR = Path(__file__).resolve().parents[1] / "src" / "synth" / "dataset" / "configs"
_CONFIG = (_CONFIG_DIR / "flying.toml").read_bytes()
_STUDY = (_CONFIG_DIR / "study-texture-window.toml").read_bytes()
_HEADER = json.dumps({"format_version": 2, "name": "planes", "format": "middlebury",
                      "config": load_config("planes").to_dict(with_count=False),
                      "config_hash": load_config("planes").hash()}, indent=2).encode()
_RECORD = json.dumps({"index": 0, "seed": 12345, "dir": "000000", "params": {"fx": 600.0},
                      "stats": {"valid": 0.5}}).encode()


def test_the_valid_documents_parse():
    assert decode_pfm(_PFM).shape == (2, 3)
    assert read_disparity(_file(_PNG16, "v.png")).shape == (2, 3)
    assert parse_calib(_CALIB.decode())["ndisp"] == 32
    assert loads_toml(_SCENE_TOML.decode()) == _SCENE == loads_json(_SCENE_JSON.decode())
    assert loads_config(_CONFIG.decode()).name == "flying"
    assert loads_study_config(_STUDY.decode()).levels


# --------------------------------------------------------------------------- one parser each
# each returns True when every reader refused the input (with one of our errors)
def _pfm(data: bytes) -> bool:
    return all([_only_ours(lambda: decode_pfm(data)),
                _only_ours(lambda: read_pfm(_file(data, "f.pfm")))])


def _png(data: bytes) -> bool:
    path = _file(data, "f.png")
    return all([_only_ours(lambda: read_disparity(path)),
                _only_ours(lambda: read_disparity(path, divisor=3)),
                _only_ours(lambda: read_image(path))])


def _calib(data: bytes) -> bool:
    return all([_only_ours(lambda: parse_calib(_text(data))),
                _only_ours(lambda: read_calib(_file(data, "calib.txt")))])


def _scene_toml(data: bytes) -> bool:
    return all([_only_ours(lambda: loads_toml(_text(data))),
                _only_ours(lambda: load_scene(_file(data, "s.toml")))])


def _scene_json(data: bytes) -> bool:
    return all([_only_ours(lambda: loads_json(_text(data))),
                _only_ours(lambda: load_scene(_file(data, "s.json")))])


def _config(data: bytes) -> bool:
    return all([_only_ours(lambda: loads_config(_text(data), source="c.toml")),
                _only_ours(lambda: load_config(_file(data, "c.toml")))])


def _study(data: bytes) -> bool:
    return all([_only_ours(lambda: loads_study_config(_text(data), source="s.toml")),
                _only_ours(lambda: load_study_config(_file(data, "study.toml")))])


def _dataset_json(data: bytes) -> bool:
    root = _WORK / "dataset"
    root.mkdir(exist_ok=True)
    (root / "dataset.json").write_bytes(data)
    # index -1: the header is read and its configuration parsed, then the index refused
    refused = _only_ours(lambda: render_from_manifest(root, -1, out=_WORK / "never"))
    assert refused and not (_WORK / "never").exists()
    return refused


def _sample_json(data: bytes) -> bool:
    sample = _WORK / "manifest" / "MiddEval3" / "trainingF" / "000000"
    sample.mkdir(parents=True, exist_ok=True)
    (sample / "sample.json").write_bytes(data)
    return _only_ours(lambda: read_manifest(_WORK / "manifest"))


PARSERS = {
    "pfm": (_pfm, _PFM),
    "png": (_png, _PNG16),
    "png8": (_png, _PNG8),
    "calib": (_calib, _CALIB),
    "scene-toml": (_scene_toml, _SCENE_TOML),
    "scene-json": (_scene_json, _SCENE_JSON),
    "dataset-config": (_config, _CONFIG),
    "study-config": (_study, _STUDY),
    "dataset.json": (_dataset_json, _HEADER),
    "sample.json": (_sample_json, _RECORD),
}


@pytest.mark.parametrize("name", sorted(PARSERS))
@FUZZ
@given(data=st.data())
def test_random_bytes_raise_only_our_errors(name, data):
    parse, valid = PARSERS[name]
    parse(data.draw(st.binary(max_size=2 * len(valid)) | st.text(max_size=200).map(str.encode),
                    label="input"))


@pytest.mark.parametrize("name", sorted(PARSERS))
@FUZZ
@given(data=st.data())
def test_mutated_documents_raise_only_our_errors(name, data):
    parse, valid = PARSERS[name]
    parse(data.draw(mutated(valid), label="input"))


# --------------------------------------------------------------------------- hand-picked
_DEEP = b"[" * 50_000
_BIG = b"1" + b"0" * 400


@pytest.mark.parametrize(("name", "data"), [
    ("scene-json", b'{"name": "x", "objects": 5}'),
    ("scene-json", _DEEP),
    ("scene-toml", b"a = " + _DEEP),
    ("scene-json", b'{"name": "x", "objects": [{"kind": "plane", "pose": {}, "size": [' + _BIG
     + b', 1]}]}'),
    ("scene-json", b'{"name": "\xff"}'),
    ("scene-json", b'{"seed": ' + b"9" * 5000 + b"}"),
    ("dataset-config", b"a = " + _DEEP),
    ("dataset-config", b"[scene]\nfrequency_px = " + _BIG + b"\n"),
    ("study-config", b"a = " + _DEEP),
    ("calib", b"cam0=[1 0 0; 0 1 0; 0 0 1]\nwidth=inf\n"),
    ("calib", b"cam0=[1 0 0; 0 1 0; 0 0 nan]\n"),
    ("calib", b"width=" + b"9" * 5000 + b"\n"),
    ("dataset.json", b"[]"),
    ("dataset.json", b"{}"),
    ("dataset.json", b'{"config": {"rig": 5}, "format": "middlebury"}'),
    ("sample.json", b"[]"),
    ("sample.json", b'{"index": "0"}'),
])
def test_known_bad_inputs(name, data):
    assert PARSERS[name][0](data), "a reader accepted a bad input"


@pytest.mark.parametrize(("read", "name"), [(load_config, "c.toml"), (load_study_config, "s.toml"),
                                            (load_scene, "s.toml"), (load_scene, "s.json"),
                                            (read_calib, "calib.txt")])
def test_files_that_are_not_text_are_our_errors(read, name):
    with pytest.raises(StereoforgeError, match=r"not (utf-8|ascii) text \(byte 8 is 0xff\)"):
        read(_file(b'name = "\xff"\n', name))


def test_a_png_announcing_40000_squared_pixels_is_a_format_error():
    import struct
    import zlib

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    data = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 40000, 40000, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\0" * 100)) + chunk(b"IEND", b""))
    with pytest.raises(StereoforgeError, match="40000x40000"):
        read_image(_file(data, "huge.png"))
