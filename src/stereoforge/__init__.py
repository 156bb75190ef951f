"""stereoforge's foundation: the exception tree and the validators every package shares.

This package imports numpy only, so every other package may import it: ``scenes`` and
``matcher`` (which otherwise stand alone, STYLE.md) as well as ``synth``. It must never import
``scenes``, ``synth`` or ``matcher``.

- :mod:`stereoforge.errors`: :class:`StereoforgeError` and its subclasses.
- :mod:`stereoforge.validation`: ``check_*`` validators and the :class:`~stereoforge.validation.Key`
  schema of configuration tables, all with one message format.
"""

from stereoforge.errors import (
    BackendError,
    ConfigError,
    DatasetError,
    FormatError,
    ParameterError,
    ParameterTypeError,
    SceneError,
    StereoforgeError,
)

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
