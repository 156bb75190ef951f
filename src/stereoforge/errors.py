"""The exceptions stereoforge raises on purpose: one base, one subclass per kind of failure.

Every class derives from :class:`StereoforgeError`, so ``except StereoforgeError`` catches any
failure the project itself reports, and from the builtin exception that callers already catch
(``ValueError``, ``TypeError`` or ``RuntimeError``), so ``except ValueError`` keeps working::

    StereoforgeError (Exception)
    +-- ParameterError (ValueError)          a value out of range, not an allowed choice, ...
    |   +-- SceneError                       a scene description (dict or file) is invalid
    +-- ParameterTypeError (TypeError, ValueError)   a value of the wrong type or dtype
    +-- ConfigError (ValueError)             a configuration file (synth.dataset's), file:line
    |   +-- synth.jobs.study.config.StudyConfigError
    +-- DatasetError (ValueError)            a dataset directory (synth.dataset.run's) or output
    |   +-- synth.OutputDirError             directory cannot be used as asked
    +-- FormatError (ValueError)             a file is truncated, corrupt or of another format
    |   +-- matcher.io.pfm.PFMError
    +-- BackendError (RuntimeError)          a rendering backend is missing or failed
    |   +-- synth.render.backend.GLBackendError    (also synth.render.GLBackendError)
    +-- synth.dataset.SampleError (RuntimeError)   one dataset sample failed

:mod:`stereoforge.validation` raises :class:`ParameterError` and :class:`ParameterTypeError`;
the domain classes are raised by the modules named above.
"""

from __future__ import annotations

__all__ = [
    "StereoforgeError",
    "ParameterError",
    "ParameterTypeError",
    "SceneError",
    "ConfigError",
    "DatasetError",
    "FormatError",
    "BackendError",
]


class StereoforgeError(Exception):
    """Base of every error stereoforge raises on purpose."""


class ParameterError(StereoforgeError, ValueError):
    """A parameter has a bad value: out of range, not an allowed choice, wrong shape, not finite.

    The message names the parameter, the expected and the actual value, and the fix (see
    :mod:`stereoforge.validation`).
    """


class ParameterTypeError(StereoforgeError, TypeError, ValueError):
    """A parameter has the wrong type or dtype.

    A ``TypeError``, and a ``ValueError`` too: a value of the wrong type is one kind of bad value,
    so the one ``except ValueError`` of a caller that reports bad input (the CLI's) catches it,
    and the call sites that raised ``ValueError`` for a wrong type before still do.
    """


class SceneError(ParameterError):
    """A scene description is invalid: an unknown or missing key, a format version or file suffix
    this version does not read."""


class ConfigError(StereoforgeError, ValueError):
    """A configuration file is invalid; the message starts with ``file:line`` and gives the fix."""


class DatasetError(StereoforgeError, ValueError):
    """A dataset or output directory cannot be used as asked (other config, busy, not a dataset)."""


class FormatError(StereoforgeError, ValueError):
    """A file is truncated, corrupt or not of the format it claims."""


class BackendError(StereoforgeError, RuntimeError):
    """A rendering backend is missing, cannot start or failed."""
