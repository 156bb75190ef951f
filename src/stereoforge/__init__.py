"""stereoforge's foundation: the exception tree and the validators every package shares.

This package imports numpy only, so every other package may import it: ``scenes`` and
``matcher`` (which otherwise stand alone, STYLE.md) as well as ``synth``. It must never import
``scenes``, ``synth`` or ``matcher``.

- :mod:`stereoforge.errors`: :class:`StereoforgeError` and its subclasses.
- :mod:`stereoforge.validation`: the ``check_*`` validators, all with one message format.
- :mod:`stereoforge.schema`: :class:`~stereoforge.schema.Key` and
  :func:`~stereoforge.schema.check_table`, declarative schemas of settings tables.
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
