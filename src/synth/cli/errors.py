"""The one error boundary of the command line: every failure becomes one ``Error:`` line.

:class:`BoundaryGroup` is the ``stereoforge`` group. Whatever a subcommand raises goes through
:func:`describe_error`, which gives the message and the exit status:

==========  ==============================================================================
exit 2      usage: a bad parameter, a bad configuration, scene or dataset file, a file of
            the wrong format, a missing input file or a directory given for one
            (``ParameterError``, ``ConfigError``, ``SceneError``, ``DatasetError``,
            ``FormatError``, ``FileNotFoundError``, ``IsADirectoryError``; click's own usage
            errors too)
exit 1      environment: the GL backend is missing or failed (``BackendError``), a dataset
            sample failed (``SampleError``), an OS error on a path (no space left, read-only,
            permission denied, a file where a directory should be), an optional package
            missing (torch, ray, fsspec, webdataset: the message names the extra), out of
            memory; and an unexpected error (a bug: the message says so)
exit 130    interrupted (Ctrl-C): one line saying what was kept and how to go on (``train``
            writes its checkpoint first and says so)
==========  ==============================================================================

``stereoforge --debug ...`` (or ``STEREOFORGE_DEBUG=1``) lets the exception through with its
traceback instead. Subcommands hold no ``try``/``except`` of their own for this.
"""

from __future__ import annotations

import errno
import os
from typing import Any

import click

from stereoforge.errors import BackendError, StereoforgeError

__all__ = ["BoundaryGroup", "describe_error", "USAGE", "ENVIRONMENT", "INTERRUPT"]

#: Exit status of a usage error (bad parameters, bad file contents): click's convention.
USAGE = 2
#: Exit status of an environment error (backend, OS, failed sample, bug).
ENVIRONMENT = 1
#: Exit status after Ctrl-C (128 + SIGINT), and what the line says: every long command writes
#: each result whole and resumes from what is there.
INTERRUPT = 130
INTERRUPTED = ("interrupted (Ctrl-C); what was complete is kept (every sample, pair and table "
               "is written whole, never in part): run the same command again to resume")

_DEBUG_KEY = "stereoforge.debug"

_OS_FIXES = {
    errno.ENOSPC: "free some space or choose another --out",
    errno.EDQUOT: "free some space (disk quota exceeded) or choose another --out",
    errno.EROFS: "the file system is read-only; choose another --out",
    errno.EACCES: "choose a path you may write (or read), or change its permissions",
    errno.EPERM: "choose a path you may write (or read), or change its permissions",
    errno.ENOTDIR: "a part of the path is a file, not a directory; choose another path",
    errno.EISDIR: "the path is a directory; give a file",
    errno.ENAMETOOLONG: "choose a shorter path",
    errno.EEXIST: "remove it or choose another path",
    errno.EMFILE: "raise the open-file limit (ulimit -n)",
}

#: Optional packages a command may need, and what installs them (a missing one is exit 1).
_OPTIONAL = {
    "torch": "pip install 'stereoforge[learn]'",
    "ray": "pip install 'stereoforge[ray]'",
    "fsspec": "pip install 'stereoforge[storage]'",
    "webdataset": "pip install 'stereoforge[webdataset]'",
}


def _os_message(exc: OSError) -> str:
    if exc.strerror is None:  # raised with a message of our own: FileNotFoundError("...")
        return str(exc)
    path = exc.filename if exc.filename2 is None else f"{exc.filename} -> {exc.filename2}"
    text = exc.strerror[:1].lower() + exc.strerror[1:]
    head = f"{os.fspath(path)}: {text}" if path is not None else text
    fix = _OS_FIXES.get(exc.errno or 0)
    if isinstance(exc, FileNotFoundError) and fix is None:
        fix = "check the path"
    return f"{head}; {fix}" if fix else head


def describe_error(exc: BaseException) -> tuple[str, int]:
    """The ``Error:`` message (without the prefix) and the exit status for ``exc``.

    Examples
    --------
    >>> from stereoforge.errors import ConfigError
    >>> describe_error(ConfigError("a.toml:3: rig.width: expected an integer, got 4.5"))
    ('a.toml:3: rig.width: expected an integer, got 4.5', 2)
    >>> describe_error(OSError(28, "No space left on device", "out/disp0.pfm"))
    ('out/disp0.pfm: no space left on device; free some space or choose another --out', 1)
    """
    if isinstance(exc, StereoforgeError):
        # failed samples and backends are the environment's fault; the rest is bad input
        environment = isinstance(exc, (BackendError, RuntimeError))
        cause = exc.__cause__
        if isinstance(cause, OSError) and not isinstance(cause, FileNotFoundError):
            environment = True
        return str(exc), ENVIRONMENT if environment else USAGE
    if isinstance(exc, (FileNotFoundError, IsADirectoryError)):  # a path the caller chose
        return _os_message(exc), USAGE
    if isinstance(exc, OSError):
        return _os_message(exc), ENVIRONMENT
    if isinstance(exc, ModuleNotFoundError) and (exc.name or "").split(".")[0] in _OPTIONAL:
        package = (exc.name or "").split(".")[0]
        return (f"this command needs the optional package {package}, which is not installed; "
                f"{_OPTIONAL[package]}", ENVIRONMENT)
    if isinstance(exc, MemoryError):
        return ("out of memory; use smaller images, fewer disparities or fewer workers",
                ENVIRONMENT)
    if isinstance(exc, ValueError) and not isinstance(exc, UnicodeError):
        # a check of the library that does not use stereoforge.errors yet: still bad input
        return str(exc), USAGE
    return (f"unexpected {type(exc).__name__}: {exc} (a bug in stereoforge; rerun with "
            "`stereoforge --debug ...` and report the traceback)", ENVIRONMENT)


def debug_requested(ctx: click.Context) -> bool:
    """``--debug`` was given (or ``STEREOFORGE_DEBUG`` is set to a non-empty value but 0)."""
    return bool(ctx.meta.get(_DEBUG_KEY)) or os.environ.get("STEREOFORGE_DEBUG", "0") not in ("", "0")


def set_debug(ctx: click.Context, _param: Any, value: bool) -> bool:
    """Callback of the group's ``--debug`` flag."""
    if value:
        ctx.meta[_DEBUG_KEY] = True
    return value


class BoundaryGroup(click.Group):
    """A click group that turns every exception of its subcommands into one ``Error:`` line.

    Click's own exceptions (usage errors, ``--help``, ``ctx.exit``, ``SystemExit``) pass
    unchanged; with ``--debug`` everything passes unchanged.
    """

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except (click.exceptions.ClickException, click.exceptions.Exit, click.Abort):
            raise
        except KeyboardInterrupt:  # Ctrl-C: one line, exit 130, as `train` documents
            if debug_requested(ctx):
                raise
            click.echo(f"Error: {INTERRUPTED}", err=True)
            ctx.exit(INTERRUPT)
        except Exception as exc:
            if debug_requested(ctx):
                raise
            message, status = describe_error(exc)
            click.echo(f"Error: {message}", err=True)
            ctx.exit(status)
