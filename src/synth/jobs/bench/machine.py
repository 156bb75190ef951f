"""What a benchmark ran on: CPU, cores, the SIMD level numba compiled for, OpenCV's dispatch
level and the GL renderer, printed and written with every benchmark table.

Speeds mean little without the machine: the census kernels' Hamming distances compile to AVX-512
``vpopcntq`` where the CPU has it and to a slower AVX2 sequence where it does not, and OpenCV
picks its own code paths at run time. Every ``stereoforge bench`` table therefore carries
:func:`describe_machine`'s facts (in the Markdown header and a ``<name>.machine.json`` beside it).
"""

from __future__ import annotations

import os
import platform
from collections.abc import Mapping
from dataclasses import asdict, dataclass

__all__ = ["MachineInfo", "describe_machine", "simd_level", "AVX2_TARGET"]

#: numba target of an AVX2-only build (``bench match --isa avx2``): Haswell, no AVX-512.
AVX2_TARGET = {
    "NUMBA_CPU_NAME": "haswell",
    "NUMBA_CPU_FEATURES": "+64bit,+avx,+avx2,+bmi,+bmi2,+cmov,+cx16,+f16c,+fma,+fsgsbase,+lzcnt,"
                          "+mmx,+movbe,+pclmul,+popcnt,+rdrnd,+sahf,+sse,+sse2,+sse3,+sse4.1,"
                          "+sse4.2,+ssse3,+xsave,+xsaveopt",
}

# SIMD levels from the widest down: (name, LLVM features that must all be enabled).
_LEVELS = (
    ("AVX-512 (VPOPCNTDQ)", ("avx512f", "avx512bw", "avx512vpopcntdq")),
    ("AVX-512", ("avx512f", "avx512bw")),
    ("AVX2", ("avx2",)),
    ("AVX", ("avx",)),
    ("SSE4.2", ("sse4.2",)),
    ("SSE2", ("sse2",)),
)


@dataclass(frozen=True)
class MachineInfo:
    """The facts a benchmark table names.

    Attributes
    ----------
    cpu : str
        CPU model (``/proc/cpuinfo``'s model name, else :func:`platform.processor`).
    cores : int
        Logical CPUs this process may use.
    numba_target : str
        The CPU numba compiles for and its SIMD level, e.g. ``znver5, AVX-512 (VPOPCNTDQ)``;
        ``(NUMBA_CPU_NAME)`` marks a target set by the environment.
    opencv_dispatch : str
        The widest of OpenCV's dispatched code paths this CPU runs, and OpenCV's baseline.
    gl_renderer : str
        ``GL_RENDERER`` of the backend a renderer would start, or why there is none.
    """

    cpu: str
    cores: int
    numba_target: str
    opencv_dispatch: str
    gl_renderer: str

    def markdown(self) -> str:
        """The facts as Markdown lines (the header of a benchmark table)."""
        return "\n".join(f"- {k.replace('_', ' ')}: {v}" for k, v in asdict(self).items())

    def to_dict(self) -> dict[str, object]:
        return asdict(self)


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def simd_level(features: str | Mapping[str, bool]) -> str:
    """The widest SIMD level of an LLVM feature list (``"+avx2,-avx512f,..."`` or a mapping).

    Examples
    --------
    >>> simd_level("+sse2,+avx,+avx2,-avx512f")
    'AVX2'
    >>> simd_level({"avx512f": True, "avx512bw": True, "avx512vpopcntdq": True, "avx2": True})
    'AVX-512 (VPOPCNTDQ)'
    """
    if isinstance(features, str):
        enabled = {f[1:] for f in features.split(",") if f.startswith("+")}
    else:
        enabled = {k for k, v in features.items() if v}
    for name, needed in _LEVELS:
        if all(n in enabled for n in needed):
            return name
    return "none above SSE2"


def _numba_target() -> str:
    import llvmlite.binding as llvm
    import numba

    name = numba.config.CPU_NAME or llvm.get_host_cpu_name()
    features = numba.config.CPU_FEATURES or llvm.get_host_cpu_features().flatten()
    source = " (NUMBA_CPU_NAME)" if numba.config.CPU_NAME else ""
    return f"{name}{source}, {simd_level(features)}"


def _opencv_dispatch() -> str:
    import cv2

    line = cv2.getCPUFeaturesLine().split()  # "SSE SSE2 SSE3 *SSE4.1 ... *AVX512-SKX"
    baseline = [f for f in line if not f.startswith("*")]
    supported = {cv2.getHardwareFeatureName(i) for i in range(1, 512)
                 if cv2.getHardwareFeatureName(i) and cv2.checkHardwareSupport(i)}
    runs = [f[1:] for f in line if f.startswith("*") and f[1:] in supported]
    widest = runs[-1] if runs and cv2.useOptimized() else (baseline[-1] if baseline else "none")
    return f"{widest} (baseline {' '.join(baseline) or 'none'}; OpenCV {cv2.__version__})"


def _gl_renderer(backend: str) -> str:
    from synth.render.backend import GLBackendError, gl_renderer_string

    try:
        return gl_renderer_string(backend)
    except GLBackendError as exc:
        return f"none ({str(exc).splitlines()[0]})"


def describe_machine(*, backend: str | None = "auto") -> MachineInfo:
    """The machine a benchmark runs on; ``backend=None`` skips the GL probe (it says so).

    The GL renderer is read by the backend probe (a subprocess), so this process stays free to
    choose its own backend afterwards.
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return MachineInfo(
        cpu=_cpu_model(),
        cores=int(cores or 1),
        numba_target=_numba_target(),
        opencv_dispatch=_opencv_dispatch(),
        gl_renderer="not used" if backend is None else _gl_renderer(backend),
    )
