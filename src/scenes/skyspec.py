"""The data of a sky at infinity (``SceneSpec.sky``); its colour model is :mod:`scenes.sky`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from stereoforge.validation import check_int, check_real, check_sequence

__all__ = ["SkySpec"]

_MAX_SEED = 2**63


def _colour(value: Any, name: str) -> tuple[float, ...]:
    return check_sequence(value, name, length=3, of="numbers",
                          item=lambda v, item: check_real(v, item, lo=0.0, hi=1.0))


@dataclass(frozen=True)
class SkySpec:
    """A procedural sky at infinity (its colour model: :mod:`scenes.sky`).

    Parameters
    ----------
    zenith, horizon, ground : (3,) tuple of float
        Display-encoded RGB in [0, 1] straight up, at the horizon and a few degrees below it.
    clouds : float
        Cloud cover in [0, 1] (0: clear).
    cloud_colour : (3,) tuple of float
        RGB of the clouds.
    cloud_scale : float
        Tiles of the cloud noise per unit of the cloud layer (one unit above the eye), > 0:
        larger means smaller clouds.
    seed : int
        Seed of the cloud noise, in [0, 2**63).
    pitch : float
        Degrees the cameras look down (the rig's pitch, :func:`scenes.posing.pitched`): the
        sky's horizon turns with the scene. Written to a scene file only when not 0.

    Examples
    --------
    >>> SkySpec().clouds
    0.3
    >>> SkySpec(clouds=2.0)
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: SkySpec.clouds: expected a finite number in [0.0, 1.0], got 2.0
    """

    zenith: tuple[float, float, float] = (0.35, 0.55, 0.85)
    horizon: tuple[float, float, float] = (0.75, 0.82, 0.9)
    ground: tuple[float, float, float] = (0.5, 0.52, 0.5)
    clouds: float = 0.3
    cloud_colour: tuple[float, float, float] = (0.95, 0.95, 0.95)
    cloud_scale: float = 0.5
    seed: int = 0
    pitch: float = field(default=0.0, metadata={"omit_default": True})

    def __post_init__(self) -> None:
        for name in ("zenith", "horizon", "ground", "cloud_colour"):
            object.__setattr__(self, name, _colour(getattr(self, name), f"SkySpec.{name}"))
        object.__setattr__(self, "clouds", check_real(self.clouds, "SkySpec.clouds",
                                                      lo=0.0, hi=1.0))
        object.__setattr__(self, "cloud_scale", check_real(
            self.cloud_scale, "SkySpec.cloud_scale", lo=0.0, lo_open=True, hi=1e3))
        object.__setattr__(self, "seed", check_int(self.seed, "SkySpec.seed", lo=0,
                                                   hi=_MAX_SEED, hi_open=True))
        object.__setattr__(self, "pitch", check_real(self.pitch, "SkySpec.pitch", lo=-90.0,
                                                     hi=90.0))
