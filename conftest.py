"""Root pytest hooks: the docstring examples that need OpenGL run only where a backend starts.

They are real doctests (they run in CI, where a backend is installed and
``STEREOFORGE_REQUIRE_GL=1`` forbids skipping); elsewhere they skip with the backend error.
"""

from __future__ import annotations

import importlib.util
import os

import pytest
from _pytest.doctest import DoctestItem

# Every Ray a test starts or joins stays on the loopback, whichever test imports Ray first: Ray
# keeps a node IP of 127.0.0.1 only with this set as it is imported (synth.dataset.engine.tasks).
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")

# The learning modules import torch (the extra 'learn', in the 'test' extra): without it their
# examples are not collected (their tests skip with the reason, or fail where
# STEREOFORGE_REQUIRE_TORCH=1, as in CI).
if importlib.util.find_spec("torch") is None:
    collect_ignore_glob = ["src/matcher/learned/*.py", "src/synth/jobs/train/*.py",
                           "src/synth/jobs/bench_transfer.py"]


def require_or_skip(reason: str, *, env: str) -> None:
    """Skip with ``reason``, or fail when the environment variable ``env`` demands the resource.

    CI sets ``STEREOFORGE_REQUIRE_GL``, ``STEREOFORGE_REQUIRE_REALDATA`` and
    ``STEREOFORGE_REQUIRE_RAY`` so that nothing it installs may be skipped.
    """
    if os.environ.get(env, "") not in ("", "0", "false", "no"):
        pytest.fail(f"{reason} ({env}=1 forbids skipping)")
    pytest.skip(reason)


@pytest.fixture(name="require_or_skip", scope="session")
def _require_or_skip_fixture():
    """:func:`require_or_skip` for test modules (conftest files are not importable by name)."""
    return require_or_skip


#: Modules whose examples render.
_GL_DOCTEST_PREFIXES = ("synth.render.", "synth.pair.", "synth.dataset.")
_gl_error: list[str | None] = []


def _gl_unavailable() -> str | None:
    if not _gl_error:
        from synth.render.renderer import GLBackendError, Renderer

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
            require_or_skip(f"example needs OpenGL: {error}", env="STEREOFORGE_REQUIRE_GL")
