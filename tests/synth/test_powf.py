"""``synth.appearance._powf.powf``: glibc's ``powf`` bit for bit, and a correct power anywhere.

The photometric gamma of blurred images goes through this port so that the same seed gives the
same bytes on every CPU (``np.power`` takes Intel's SVML on AVX-512 machines). Where the
process's C library is glibc's ``powf`` of the FMA build (glibc >= 2.28 on an x86-64 CPU with
FMA, the machines this project runs on), the port must equal it on every value; everywhere it
must be within glibc's documented 0.82 ULP of the exact power.
"""

from __future__ import annotations

import platform

import numpy as np
import pytest
from numba import njit

from synth.appearance._powf import powf


@njit(cache=True)
def _libm_powf(x, y, out):  # pragma: no cover - compiled
    for i in range(x.size):  # float32 ** float32: a call of the C library's powf
        out[i] = x[i] ** y


def _cpu_flags() -> set[str]:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def _glibc_fma_powf() -> str | None:
    """Why the process's ``powf`` is not glibc's FMA build, or None when it is."""
    libc, version = platform.libc_ver()
    if libc != "glibc" or tuple(int(v) for v in version.split(".")[:2]) < (2, 28):
        return f"the C library is {libc or 'unknown'} {version}, not glibc >= 2.28"
    if platform.machine() != "x86_64" or not {"fma", "avx2"} <= _cpu_flags():
        return f"glibc picks its FMA powf on x86-64 with FMA and AVX2 only ({platform.machine()})"
    return None


def _values(rng: np.random.Generator) -> np.ndarray:
    """Images' values (0..1 and a little over, as after a blur divided by 255), a log-uniform
    sweep of every binade, and the special inputs."""
    unit = rng.random(1_500_000, dtype=np.float32) * np.float32(1.02)
    wide = np.exp2(rng.uniform(-149, 128, 500_000)).astype(np.float32)
    special = np.array([0.0, -0.0, 1.0, -1.0, 2.0, np.inf, -np.inf, np.nan, 1e-45, 1e-40,
                        1.1754942e-38, 1.1754944e-38, 3.4028235e38, -0.5, 0.5, 1 - 2**-24,
                        1 + 2**-23], dtype=np.float32)
    return np.concatenate([unit, wide, special, np.nextafter(unit[:1000], np.float32(2))])


EXPONENTS = [0.1, 0.45, 1 / 2.2, 0.8, 1.0, 1.3, 2.2, 3.0, 7.7, 10.0, 1e-3, 25.0, 150.0]


@pytest.mark.skipif(_glibc_fma_powf() is not None, reason=str(_glibc_fma_powf()))
@pytest.mark.parametrize("y", EXPONENTS)
def test_powf_equals_glibcs_powf_bit_for_bit(y):
    x = _values(np.random.default_rng(int(y * 1000)))
    expected = np.empty_like(x)
    _libm_powf(x, np.float32(y), expected)
    got = powf(x, y)
    differ = got.view(np.uint32) != expected.view(np.uint32)
    differ &= ~(np.isnan(got) & np.isnan(expected))  # NaN payloads aside
    assert not differ.any(), (x[differ][:5], got[differ][:5], expected[differ][:5])


@pytest.mark.parametrize("y", EXPONENTS + [-0.5, -2.0, 0.0])
def test_powf_is_within_glibcs_bound_of_the_exact_power(y):
    x = _values(np.random.default_rng(7))
    x = x[np.isfinite(x) & (x > 0)]
    got = powf(x, y).astype(np.float64)
    with np.errstate(over="ignore", under="ignore"):
        exact = np.power(x.astype(np.float64), np.float64(np.float32(y)))
    # normal float32 results below the largest binade (whose spacing() overflows)
    ok = (exact >= np.finfo(np.float32).tiny) & (exact < 2.0**127)
    assert ok.sum() > 100_000
    ulp = np.spacing(exact[ok].astype(np.float32)).astype(np.float64)
    assert (np.abs(got[ok] - exact[ok]) <= 0.82 * ulp).all()


def test_powf_special_values_follow_ieee_754():
    x = np.array([0.0, -0.0, np.inf, np.nan, 1.0, -8.0, 1e-45], np.float32)
    with np.errstate(invalid="ignore", divide="ignore"):
        expected = np.power(x, np.float32(3.0))
    got = powf(x, 3.0)
    np.testing.assert_array_equal(got, expected)  # NaN == NaN here
    assert np.signbit(got[1]) == np.signbit(expected[1])


def test_scaled_powf_is_the_float32_products_around_the_power():
    x = (np.random.default_rng(3).random((30, 40, 3), dtype=np.float32) * 255)
    got = powf(x, 1.37, pre=1 / 255, post=255)
    inner = powf(x * np.float32(1 / 255), 1.37)
    np.testing.assert_array_equal(got, inner * np.float32(255))
    assert got.shape == x.shape and got.dtype == np.float32


def test_powf_refuses_what_it_cannot_read():
    with pytest.raises(TypeError, match="C-contiguous float32"):
        powf(np.zeros(4), 2.0)
    with pytest.raises(TypeError, match="C-contiguous float32"):
        powf(np.zeros((4, 4), np.float32)[:, ::2], 2.0)
