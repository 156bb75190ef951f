"""Where a key sits in TOML text: the line numbers of configuration error messages."""

from __future__ import annotations

import re

__all__ = ["line_of"]

_HEADER = re.compile(r"^\s*\[\s*([A-Za-z0-9_.\-\"' ]+?)\s*\]\s*(#.*)?$")


def line_of(text: str, section: str, key: str | None) -> int | None:
    """1-based line of ``key`` in ``[section]`` (or of the section header), else ``None``."""
    current = ""
    header_line = None
    key_re = re.compile(r"^\s*[\"']?" + re.escape(key) + r"[\"']?\s*[=.]") if key else None
    dotted = re.compile(r"^\s*" + re.escape(section) + r"\s*\.\s*" + re.escape(key or "") + r"\s*=") \
        if section and key else None
    for no, line in enumerate(text.splitlines(), start=1):
        m = _HEADER.match(line)
        if m:
            current = m.group(1).strip().strip("\"'")
            if section == "" and key is not None and current == key:
                return no
            if current == section and header_line is None:
                header_line = no
            continue
        if key_re is not None and current == section and key_re.match(line):
            return no
        if dotted is not None and current == "" and dotted.match(line):
            return no
    return header_line
