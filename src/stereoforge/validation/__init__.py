"""One way to check input: small validators with one message format.

Every check takes the value and the parameter's name (and optionally ``where``: a ``file:line``,
a configuration key path or an object such as ``objects[2]``), returns the value converted to a
plain Python or numpy type, and on bad input raises :class:`~stereoforge.errors.ParameterError`
(a ``ValueError``) or, for a wrong type or dtype, :class:`~stereoforge.errors.ParameterTypeError`
(a ``TypeError``) whose message reads::

    [<where>: ]<name>: expected <what is allowed>, got <what was given>[; <the fix>]

:func:`fail` builds that message for checks of one's own (a relation between two parameters,
say), so every error reads the same. :mod:`stereoforge.schema` builds on these to describe and
check a whole table of settings (the dataset and study configurations).

One idea, one package: the message format and the checks of scalars, sequences, keys, text and
files (:mod:`~stereoforge.validation.checks`), of arrays (:mod:`~stereoforge.validation.arrays`)
and of camera geometry (:mod:`~stereoforge.validation.geometry`); most of their length is the
doctests that show each message. Import the checks from here.

Examples
--------
>>> check_real(0.5, "contrast", lo=0.0, hi=1.0)
0.5
>>> check_int(4, "window", lo=3, odd=True)
Traceback (most recent call last):
...
stereoforge.errors.ParameterError: window: expected an odd integer >= 3, got 4
>>> check_choice("perlin", "kind", ("noise", "checker"), where="objects[0].texture")
Traceback (most recent call last):
...
stereoforge.errors.ParameterError: objects[0].texture: kind: expected one of ['noise', 'checker'], got 'perlin'

One package on purpose: the validators share one message format, which is the point of having them.
"""

from stereoforge.validation.arrays import check_array, check_dtype, check_finite, check_shape
from stereoforge.validation.checks import (check_bool, check_choice, check_input_file, check_int,
                                           check_keys, check_real, check_sequence, check_text,
                                           check_type, describe, fail, range_text)
from stereoforge.validation.geometry import MAX_TANGENTIAL, check_distortion, check_rotation_deg

__all__ = [
    "describe",
    "range_text",
    "fail",
    "check_type",
    "check_bool",
    "check_int",
    "check_real",
    "check_rotation_deg",
    "check_distortion",
    "check_choice",
    "check_sequence",
    "check_array",
    "check_dtype",
    "check_shape",
    "check_finite",
    "check_keys",
    "check_text",
    "check_input_file",
]
