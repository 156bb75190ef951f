"""Properties of the TOML key locator (synth._util.toml_lines): every key maps to the line it is on.

The documents are generated with the line of every key known by construction: tables, arrays of
tables, dotted and quoted keys, inline tables, arrays over several lines, and strings (basic,
literal, multi-line) and comments full of text that looks like headers and keys.
"""

from __future__ import annotations

import tomllib

from hypothesis import given
from hypothesis import strategies as st

from synth._util.toml_lines import key_lines, line_of

# Text that a naive line matcher takes for a header or a key.
DECOYS = ["[scene]", "[[objects]]", "occluders = 1", "k0 = 2", "[t0]", "a.b = 3", "x = { y = 1 }",
          "# not a comment", "[rig] # c", "'''", '"', "'", "\\t", "=", "]"]

names = st.sampled_from(["k0", "k1", "k2", "k3", "occluders", "width", "1a", "b-c", "kind"])
quoted = st.sampled_from(['"a.b"', "'c d'", '"[e]"', '"k\\u0030"'])  # "k\u0030" is k0 decoded
_QUOTED_KEYS = {'"a.b"': "a.b", "'c d'": "c d", '"[e]"': "[e]", '"k\\u0030"': "k0"}


@st.composite
def strings(draw) -> str:
    """A TOML string literal, maybe over several lines."""
    kind = draw(st.sampled_from(["basic", "literal", "ml_basic", "ml_literal"]))
    decoys = draw(st.lists(st.sampled_from(DECOYS), min_size=0, max_size=4))
    if kind == "basic":
        return '"' + " ".join(d.replace("\\", "\\\\").replace('"', '\\"') for d in decoys) + '"'
    if kind == "literal":
        return "'" + " ".join(d for d in decoys if "'" not in d) + "'"
    if kind == "ml_basic":
        body = "\n".join(d.replace("\\", "\\\\").replace('"', '\\"') for d in decoys)
        tail = draw(st.sampled_from(["", '"', '""', '\\"']))  # quotes right before the end
        return '"""' + draw(st.sampled_from(["", "\n"])) + body + tail + '"""'
    body = "\n".join(d for d in decoys if "'" not in d)
    tail = draw(st.sampled_from(["", "'", "''"]))
    return "'''" + draw(st.sampled_from(["", "\n"])) + body + tail + "'''"


def _lines_in(text: str) -> int:
    return text.count("\n")


@st.composite
def values(draw, depth: int = 0):
    """``(text, {relative path: line offset})`` of a value."""
    options = ["int", "string"] + (["inline", "array"] if depth < 2 else [])
    kind = draw(st.sampled_from(options))
    if kind == "int":
        return str(draw(st.integers(-5, 5))), {}
    if kind == "string":
        return draw(strings()), {}
    if kind == "inline":
        keys = draw(st.lists(names, min_size=0, max_size=3, unique=True))
        text, paths = "{", {}
        for i, key in enumerate(keys):
            sub, subpaths = draw(values(depth + 1))
            text += (", " if i else " ") + f"{key} = "
            offset = _lines_in(text)
            paths[(key,)] = offset
            paths.update({(key, *p): offset + o for p, o in subpaths.items()})
            text += sub
        return text + " }", paths
    n = draw(st.integers(0, 3))
    sep = draw(st.sampled_from([", ", ",\n  ", ", # [c] = 1\n  "]))
    text, paths = "[", {}
    for i in range(n):
        sub, subpaths = draw(values(depth + 1))
        text += sep if i else draw(st.sampled_from(["", "\n  "]))
        offset = _lines_in(text)
        paths[(i,)] = offset
        paths.update({(i, *p): offset + o for p, o in subpaths.items()})
        text += sub
    return text + draw(st.sampled_from(["]", "\n]"] + ([",\n]"] if n else []))), paths


class _Doc:
    def __init__(self) -> None:
        self.text = ""
        self.expected: dict[tuple, int] = {}

    @property
    def line(self) -> int:
        return self.text.count("\n") + 1

    def emit(self, text: str) -> None:
        self.text += text + "\n"


@st.composite
def key_values(draw, doc: _Doc, prefix: tuple) -> None:
    """A few ``key = value`` lines (plain, quoted or dotted keys) under ``prefix``."""
    keys = draw(st.lists(st.one_of(names, quoted), min_size=0, max_size=3,
                         unique_by=lambda k: _QUOTED_KEYS.get(k, k)))
    for key in keys:
        if draw(st.booleans()):
            doc.emit(draw(st.sampled_from(["", "# [t9] k0 = 1", "   # [[x]]"])))
        path = (*prefix, _QUOTED_KEYS.get(key, key))
        if key in ("k3", "kind") and draw(st.booleans()):  # a dotted key k3.sub = ...
            key, path = f"{key} . sub", (*path, "sub")
            doc.expected.setdefault(path[:-1], doc.line)
        value, paths = draw(values())
        line = doc.line
        doc.expected[path] = line
        doc.expected.update({(*path, *p): line + o for p, o in paths.items()})
        doc.emit(f"{key} = {value}" + draw(st.sampled_from(["", "  # = [x]"])))


@st.composite
def documents(draw):
    """``(toml text, {key path: line})``."""
    doc = _Doc()
    draw(key_values(doc, ()))
    for table in draw(st.lists(st.sampled_from(["t0", "t1", "rig"]), max_size=2, unique=True)):
        doc.expected[(table,)] = doc.line
        doc.emit(draw(st.sampled_from([f"[{table}]", f"[ {table} ]  # [x]", f'["{table}"]'])))
        draw(key_values(doc, (table,)))
    if draw(st.booleans()):
        for i in range(draw(st.integers(1, 3))):
            doc.expected.setdefault(("objects",), doc.line)
            doc.expected[("objects", i)] = doc.line
            doc.emit("[[objects]]")
            draw(key_values(doc, ("objects", i)))
            if draw(st.booleans()):
                doc.expected[("objects", i, "pose")] = doc.line
                doc.emit("[objects.pose]")
                draw(key_values(doc, ("objects", i, "pose")))
    return doc.text, doc.expected


@given(documents())
def test_every_key_is_found_on_its_line(doc):
    text, expected = doc
    tomllib.loads(text)  # the generator writes valid TOML
    lines = key_lines(text)
    wrong = {path: (line, lines.get(path)) for path, line in expected.items()
             if lines.get(path) != line}
    assert wrong == {}, text
    for path, line in expected.items():
        assert line_of(text, *path) == line


@given(documents(), st.sampled_from(["missing", "also_missing"]))
def test_an_unknown_key_falls_back_to_its_table(doc, key):
    text, expected = doc
    for path, line in expected.items():
        if len(path) == 1 and isinstance(path[0], str) and path[0] in ("t0", "t1", "rig"):
            assert line_of(text, *path, key) == line
    assert line_of(text, key) is None


def test_hand_picked_document():
    text = (
        'name = """\n'          # 1
        "[scene]\n"             # 2
        "occluders = 3\n"       # 3
        '"""\n'                 # 4
        "[scene]  # the real one\n"  # 5
        "occluders = 2\n"       # 6
        'rig = { width = 4, "fx" = 1.0 }\n'  # 7
        "windows = [\n"         # 8
        "  5,\n"                # 9
        "  {w = 7},\n"          # 10
        "]\n"                   # 11
        "[[objects]]\n"         # 12
        "kind = '''x'''\n"      # 13
        "[[objects]]\n"         # 14
        "size.x = 1\n"          # 15
    )
    lines = key_lines(text)
    assert lines[("scene", "occluders")] == 6
    assert lines[("scene", "rig", "width")] == 7 and lines[("scene", "rig", "fx")] == 7
    assert lines[("scene", "windows", 0)] == 9 and lines[("scene", "windows", 1, "w")] == 10
    assert lines[("objects", 0, "kind")] == 13 and lines[("objects", 1, "size", "x")] == 15
    assert line_of(text, "scene", "nope") == 5
