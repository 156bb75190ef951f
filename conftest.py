"""Root pytest hooks: the docstring examples that need OpenGL run only where a backend starts.

They are real doctests (they run in CI, where a backend is installed and
``STEREOFORGE_REQUIRE_GL=1`` forbids skipping); elsewhere they skip with the backend error.
"""

from __future__ import annotations

import os

import pytest
from _pytest.doctest import DoctestItem

#: Modules whose examples render.
_GL_DOCTEST_PREFIXES = ("synth.render.", "synth.pair.", "synth.dataset.")
_gl_error: list[str | None] = []


def _gl_unavailable() -> str | None:
    if not _gl_error:
        from synth.render import GLBackendError, Renderer

        try:
            with Renderer(8, 8):
                pass
            _gl_error.append(None)
        except GLBackendError as exc:
            _gl_error.append(str(exc))
    return _gl_error[0]


@pytest.fixture(autouse=True)
def _gl_doctests(request: pytest.FixtureRequest) -> None:
    item = request.node
    if isinstance(item, DoctestItem) and item.name.startswith(_GL_DOCTEST_PREFIXES):
        error = _gl_unavailable()
        if error is not None:
            reason = f"example needs OpenGL: {error}"
            if os.environ.get("STEREOFORGE_REQUIRE_GL", "") not in ("", "0", "false", "no"):
                pytest.fail(f"{reason} (STEREOFORGE_REQUIRE_GL=1 forbids skipping)")
            pytest.skip(reason)
