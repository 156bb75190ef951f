"""Shared pytest configuration: hypothesis profiles and the real-data location."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

# Deterministic and bounded: what CI runs (`--hypothesis-profile=ci`, also the default).
settings.register_profile(
    "ci",
    derandomize=True,
    max_examples=25,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
# Deep runs: `pytest --hypothesis-profile=thorough`.
settings.register_profile(
    "thorough",
    max_examples=1000,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

_DEFAULT_MIDDLEBURY = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "middlebury"
_DEFAULT_DEV = _DEFAULT_MIDDLEBURY.parent / "dev"


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--middlebury",
        default=None,
        help="folder with the Middlebury scenes (half/, third/); default: "
        "$STEREOFORGE_MIDDLEBURY or ../shared/data/middlebury",
    )


@pytest.fixture(scope="session")
def middlebury_dir(request: pytest.FixtureRequest, require_or_skip) -> Path:
    """The Middlebury data folder; skips (with the reason) only where it is absent.

    In CI ``STEREOFORGE_REQUIRE_REALDATA=1`` turns the skip into a failure.
    """
    opt = request.config.getoption("--middlebury")
    path = Path(opt or os.environ.get("STEREOFORGE_MIDDLEBURY") or _DEFAULT_MIDDLEBURY)
    if not (path / "third").is_dir():
        reason = (
            f"Middlebury data not found at {path} (expected {path}/third/<Scene>/view1.png); "
            "pass --middlebury DIR or set STEREOFORGE_MIDDLEBURY"
        )
        require_or_skip(reason, env="STEREOFORGE_REQUIRE_REALDATA")
    return path


@pytest.fixture(scope="session")
def dev_data_dir(require_or_skip) -> Path:
    """The real scenes outside the lab (ETH3D, DrivingStereo, KITTI: evaluation only); skips
    (with the reason) only where they are absent.

    In CI ``STEREOFORGE_REQUIRE_DEVDATA=1`` turns the skip into a failure.
    """
    path = Path(os.environ.get("STEREOFORGE_DEV_DATA") or _DEFAULT_DEV)
    if not (path / "eth3d").is_dir() or not (path / "drivingstereo").is_dir():
        require_or_skip(f"development scenes not found at {path} (expected {path}/eth3d/ and "
                        f"{path}/drivingstereo/); set STEREOFORGE_DEV_DATA",
                        env="STEREOFORGE_REQUIRE_DEVDATA")
    return path
