"""The exception tree: one base, the builtin bases callers catch, the old import paths."""

from __future__ import annotations

import pickle
import subprocess
import sys

import pytest

import stereoforge
from matcher.io import PFMError
from stereoforge import errors
from synth.dataset.config.parse import ConfigError
from synth.dataset.run import DatasetError, SampleError
from synth.write.export import OutputDirError
from synth.render.renderer import GLBackendError
from synth.jobs.study.run import StudyConfigError


@pytest.mark.parametrize(
    ("cls", "base", "builtins"),
    [
        (errors.ParameterError, errors.StereoforgeError, (ValueError,)),
        (errors.ParameterTypeError, errors.StereoforgeError, (TypeError, ValueError)),
        (errors.SceneError, errors.ParameterError, (ValueError,)),
        (ConfigError, errors.StereoforgeError, (ValueError,)),
        (StudyConfigError, errors.ConfigError, (ValueError,)),
        (DatasetError, errors.StereoforgeError, (ValueError,)),
        (OutputDirError, errors.DatasetError, (ValueError,)),
        (PFMError, errors.FormatError, (ValueError,)),
        (GLBackendError, errors.BackendError, (RuntimeError,)),
        (SampleError, errors.StereoforgeError, (RuntimeError,)),
    ],
)
def test_every_error_has_the_one_base_and_its_builtin_base(cls, base, builtins):
    assert issubclass(cls, base) and issubclass(cls, errors.StereoforgeError)
    for builtin in builtins:
        assert issubclass(cls, builtin)


def test_old_import_paths_give_the_same_classes():
    from synth.render.backend import GLBackendError as backend_error
    from synth.jobs.study.config import StudyConfigError as study_error

    assert ConfigError is errors.ConfigError and DatasetError is errors.DatasetError
    assert backend_error is GLBackendError and study_error is StudyConfigError
    assert set(stereoforge.__all__) == set(errors.__all__)


def test_a_failed_sample_is_not_a_value_error():
    # the CLI catches ValueError (bad input) before SampleError (reproduce the sample)
    assert not issubclass(SampleError, ValueError)
    assert not issubclass(GLBackendError, ValueError)


@pytest.mark.parametrize("cls", [errors.ParameterError, errors.ParameterTypeError,
                                 ConfigError, StudyConfigError, DatasetError, PFMError])
def test_errors_pickle_across_processes(cls):
    exc = cls("my.toml:3: rig.width: expected an integer, got 4.5")
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is cls and str(back) == str(exc)
    sample = pickle.loads(pickle.dumps(SampleError(3, 7, "boom")))
    assert (sample.index, sample.seed, sample.cause) == (3, 7, "boom")


def test_except_value_error_still_catches_type_errors_of_validators():
    from stereoforge.validation import check_int

    with pytest.raises(ValueError, match="expected an integer"):
        check_int("3", "window")
    with pytest.raises(TypeError, match="expected an integer"):
        check_int("3", "window")


def test_stereoforge_imports_numpy_only():
    code = (
        "import sys, stereoforge, stereoforge.validation\n"
        "mods = {m.split('.')[0] for m in sys.modules}\n"
        "print(sorted(mods & {'synth', 'scenes', 'matcher', 'scipy', 'cv2', 'numba', 'trimesh'}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
