"""Fixtures of the synth tests: one GL renderer for the whole session."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

from synth.render.renderer import GLBackendError, Renderer


@pytest.fixture(scope="session")
def renderer(require_or_skip) -> Iterator[Renderer]:
    """A 64 x 48 renderer (it resizes to other rigs); skips without GL unless CI requires it.

    ``STEREOFORGE_TEST_GL_BACKEND=osmesa`` runs the suite on OSMesa (default: auto).
    """
    try:
        r = Renderer(64, 48, backend=os.environ.get("STEREOFORGE_TEST_GL_BACKEND", "auto"))
    except GLBackendError as exc:
        require_or_skip(f"no OpenGL backend: {exc}", env="STEREOFORGE_REQUIRE_GL")
    with r:
        yield r


@pytest.fixture(scope="module")
def tiny_suite(request) -> Iterator[None]:
    """The validate quick suite shrunk to the test module's ``TINY`` (size and seeds) while the
    module runs (the CLI's runs are in-process, so they see it too)."""
    from synth.validate import axes

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(axes.SUITES, "quick", request.module.TINY)
        yield


def _sigkill_after_records(proc, out, records: int = 1, *, timeout: float = 120.0) -> None:
    """SIGKILL ``proc`` (a dataset run writing into ``out``) once ``records`` samples have
    their completion record (``out/records/*.json``); kill it anyway if the test fails first."""
    import signal
    import time

    try:
        deadline = time.monotonic() + timeout
        while len(list((out / "records").glob("*.json")) if (out / "records").is_dir()
                   else []) < records:
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.005)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.fixture
def sigkill_after_records():
    """:func:`_sigkill_after_records`: kill a dataset run mid-way, its first records written."""
    return _sigkill_after_records
