"""Every option that more than one command takes, defined once (pip-tools' ``scripts/options.py``).

Choice lists come from the library's own constants (``synth.render.BACKENDS``,
``synth.formats.FORMATS``, ``matcher.METHODS``, ``synth.dataset.ENGINES``), loaded when a
command needs them, so that ``stereoforge --help`` imports neither numba nor trimesh.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from synth.formats import DEFAULT_FORMAT

__all__ = [
    "note",
    "LazyChoice",
    "backend_option",
    "engine_option",
    "address_option",
    "fail",
    "format_option",
    "method_option",
    "out_dir_option",
    "overwrite_option",
    "size_options",
    "workers_option",
]


class LazyChoice(click.Choice):
    """A :class:`click.Choice` whose values are a library constant, imported on first use.

    ``LazyChoice("synth.render:BACKENDS", extra=("auto",))`` accepts ``auto`` and every backend.
    """

    def __init__(self, target: str, *, extra: tuple[str, ...] = ()) -> None:
        self._target, self._extra, self._loaded = target, extra, None
        self.case_sensitive = True

    @property
    def choices(self) -> tuple[str, ...]:  # type: ignore[override]
        if self._loaded is None:
            module, name = self._target.split(":")
            self._loaded = (*self._extra, *getattr(importlib.import_module(module), name))
        return self._loaded


def note(text: str) -> None:
    """A progress remark on stderr (kept out of the command's own output)."""
    click.echo(text, err=True)


def fail(exc: Exception) -> None:
    """Report ``exc`` as one ``Error:`` line with click's usage-error exit status (2)."""
    raise click.UsageError(str(exc)) from exc


_Decorator = Callable[[Callable[..., Any]], Callable[..., Any]]


def backend_option(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--backend`` (auto, then each GL backend the renderer knows)."""
    return click.option("--backend", default="auto", show_default=True,
                        type=LazyChoice("synth.render.backend:BACKENDS", extra=("auto",)),
                        help="OpenGL backend: auto tries EGL, then OSMesa.")(f)


def format_option(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--format`` (every layout :func:`synth.write_pair` writes)."""
    return click.option("--format", "fmt", default=DEFAULT_FORMAT, show_default=True,
                        type=LazyChoice("synth.formats:FORMATS"))(f)


def method_option(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--method`` (every method :func:`matcher.match` runs)."""
    return click.option("--method", default="ct", show_default=True,
                        type=LazyChoice("matcher:METHODS"))(f)


def engine_option(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--engine`` (every dataset engine)."""
    return click.option("--engine", default="local", show_default=True,
                        type=LazyChoice("synth.dataset.engine.tasks:ENGINES"))(f)


def address_option(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--address`` (the Ray cluster of ``--engine ray``)."""
    return click.option("--address", default=None, metavar="HOST:PORT",
                        help="Ray cluster address (engine ray); default: a local Ray on "
                             "127.0.0.1.")(f)


def workers_option(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--workers`` (worker processes; 1 runs in this process)."""
    return click.option("--workers", default=1, show_default=True, type=click.IntRange(min=1))(f)


def overwrite_option(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--overwrite``."""
    return click.option("--overwrite", is_flag=True,
                        help="Write into a non-empty output directory.")(f)


def out_dir_option(*, default: str | None = None, help: str | None = None,
                   required: bool | None = None, url: bool = False) -> _Decorator:
    """``--out DIRECTORY``: required unless a default is given (or ``required=False``: the
    command checks it). ``url``: also an fsspec URL (``s3://...``), passed on as a string."""
    required = default is None if required is None else required
    return click.option("--out", "out", required=required, default=default,
                        show_default=default is not None, help=help,
                        type=str if url else click.Path(file_okay=False, path_type=Path))


def size_options(*, width: int, height: int, minimum: int = 1) -> _Decorator:
    """``--width`` and ``--height`` in pixels."""
    def decorate(f: Callable[..., Any]) -> Callable[..., Any]:
        f = click.option("--height", default=height, show_default=True,
                         type=click.IntRange(min=minimum))(f)
        return click.option("--width", default=width, show_default=True,
                            type=click.IntRange(min=minimum))(f)
    return decorate
