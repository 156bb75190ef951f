"""Offscreen OpenGL contexts from PyOpenGL's own EGL and OSMesa bindings.

The renderer draws only into its own framebuffer objects, so a context needs no window and no
usable default framebuffer: EGL makes it current with no surface (``EGL_KHR_surfaceless_context``)
or else on a 1 x 1 pbuffer; OSMesa on a 1 x 1 client buffer. Both ask for a core profile of
:data:`GL_VERSION`, the version of the shaders (``#version 330 core``); Mesa gives its highest
core version (4.5 for llvmpipe) for any core request.

PyOpenGL binds one platform per process, from ``PYOPENGL_PLATFORM`` at its first import:
:func:`open_context` sets it before importing OpenGL, and refuses a platform other than the one
already bound. The system libraries are looked for first, so a missing one is named with the
Debian package that ships it.
"""

from __future__ import annotations

import ctypes
import os
import sys
from typing import Any

from synth.render.backend import BACKENDS, DEBIAN_FIX, GLBackendError, platform_in_use

__all__ = ["GL_VERSION", "EGL_DISPLAYS", "EGLContext", "OSMesaContext", "open_context"]

#: Core-profile OpenGL version the shaders need.
GL_VERSION = (3, 3)
#: How :class:`EGLContext` gets a display, in the order it tries them.
EGL_DISPLAYS = ("device", "surfaceless", "default")
PIP_FIX = "pip install 'PyOpenGL>=3.1.7'"
_EGL_PLATFORM_SURFACELESS_MESA = 0x31DD  # EGL_MESA_platform_surfaceless (not in PyOpenGL)
# The system libraries each backend loads: (what to call it, PyOpenGL's names, Debian's fix).
_SYSTEM_LIBS = {
    "egl": (("libEGL.so.1", ("EGL",), DEBIAN_FIX["egl"]),
            ("libOpenGL.so.0 or libGL.so.1", ("OpenGL", "GL"), "apt-get install libopengl0")),
    "osmesa": (("libOSMesa.so", ("OSMesa",), DEBIAN_FIX["osmesa"]),),
}


def _loads(name: str) -> bool:
    """Whether ``lib<name>`` loads under a file name PyOpenGL tries (``.so``, ``.so.9`` .. ``.0``)."""
    for suffix in ("", *(f".{v}" for v in range(9, -1, -1))):
        try:
            ctypes.CDLL(f"lib{name}.so{suffix}")
            return True
        except OSError:
            pass
    return False


def _check_system_libs(backend: str) -> None:
    """Name a missing system library (and its Debian package) before PyOpenGL fails on it."""
    for shown, names, fix in _SYSTEM_LIBS[backend]:
        if not any(_loads(n) for n in names):
            raise GLBackendError(f"{shown} not found", fix=fix)


def _import_gl(backend: str) -> None:
    """Bind PyOpenGL to ``backend`` (at its first import) or check it is already bound to it."""
    _check_system_libs(backend)
    if "OpenGL" not in sys.modules:
        os.environ["PYOPENGL_PLATFORM"] = backend  # read once, by PyOpenGL's first import
    try:
        from OpenGL import GL  # noqa: F401  (loads the platform)
    except ModuleNotFoundError as exc:
        raise GLBackendError(f"PyOpenGL is not installed ({exc})", fix=PIP_FIX) from exc
    locked = platform_in_use()
    if locked != backend:
        raise GLBackendError(
            f"PyOpenGL is already bound to the {locked!r} platform in this process "
            "(it reads PYOPENGL_PLATFORM once, at import)",
            fix=f"open the {backend} context in a fresh process, or use backend={locked!r}")


def _address(handle: Any) -> int | None:
    """The pointer value of a PyOpenGL opaque handle (``None`` for a null one)."""
    return ctypes.cast(handle, ctypes.c_void_p).value


class EGLContext:
    """A headless EGL context (``EGL_OPENGL_API``, core profile :data:`GL_VERSION`).

    Parameters
    ----------
    displays : sequence of {"device", "surfaceless", "default"}
        Ways to get a display, tried in order until one initialises: the first device of
        ``EGL_EXT_platform_device``, Mesa's ``EGL_MESA_platform_surfaceless``, then
        ``eglGetDisplay(EGL_DEFAULT_DISPLAY)``.
    pbuffer : bool
        Make the context current on a 1 x 1 pbuffer even where the display supports
        ``EGL_KHR_surfaceless_context`` (without it, a pbuffer is used anyway).

    Notes
    -----
    Every context on a device shares one ``EGLDisplay``: :meth:`destroy` destroys only this
    context (and its pbuffer), never terminates the display, so other contexts stay usable.
    """

    def __init__(self, *, displays: tuple[str, ...] = EGL_DISPLAYS, pbuffer: bool = False) -> None:
        unknown = [d for d in displays if d not in EGL_DISPLAYS]
        if unknown or not displays:
            raise ValueError(f"displays must be a non-empty sequence of {EGL_DISPLAYS}, "
                             f"got {displays!r}")
        _import_gl("egl")
        from OpenGL import EGL

        self.display_kind, self._display = self._initialise(tuple(displays))
        configs = (EGL.EGLConfig * 1)()
        count = EGL.EGLint()
        wanted = [EGL.EGL_SURFACE_TYPE, EGL.EGL_PBUFFER_BIT,
                  EGL.EGL_RENDERABLE_TYPE, EGL.EGL_OPENGL_BIT,
                  EGL.EGL_RED_SIZE, 8, EGL.EGL_GREEN_SIZE, 8, EGL.EGL_BLUE_SIZE, 8, EGL.EGL_NONE]
        if not EGL.eglChooseConfig(self._display, wanted, configs, 1, count) or count.value < 1:
            raise GLBackendError(f"the {self.display_kind} display has no OpenGL "
                                 "pbuffer configuration", fix=DEBIAN_FIX["egl"])
        if not EGL.eglBindAPI(EGL.EGL_OPENGL_API):
            raise GLBackendError("eglBindAPI(EGL_OPENGL_API) failed: this EGL has no "
                                 "desktop OpenGL", fix=DEBIAN_FIX["egl"])
        attributes = [EGL.EGL_CONTEXT_MAJOR_VERSION, GL_VERSION[0],
                      EGL.EGL_CONTEXT_MINOR_VERSION, GL_VERSION[1],
                      EGL.EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL.EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                      EGL.EGL_NONE]
        config = configs[0]
        self._context = EGL.eglCreateContext(self._display, config, EGL.EGL_NO_CONTEXT,
                                             attributes)
        if not _address(self._context):
            raise GLBackendError(
                f"no OpenGL {GL_VERSION[0]}.{GL_VERSION[1]} core context on the "
                f"{self.display_kind} display", fix=DEBIAN_FIX["egl"])
        extensions = EGL.eglQueryString(self._display, EGL.EGL_EXTENSIONS).split()
        self._surface = EGL.EGL_NO_SURFACE
        if pbuffer or b"EGL_KHR_surfaceless_context" not in extensions:
            self._surface = EGL.eglCreatePbufferSurface(
                self._display, config, [EGL.EGL_WIDTH, 1, EGL.EGL_HEIGHT, 1, EGL.EGL_NONE])
        self.make_current()

    @staticmethod
    def _initialise(displays: tuple[str, ...]) -> tuple[str, Any]:
        from OpenGL import EGL

        client = (EGL.eglQueryString(EGL.EGL_NO_DISPLAY, EGL.EGL_EXTENSIONS) or b"").split()
        tried = []
        for kind in displays:
            display = _get_display(kind, client)
            if display is None:
                tried.append(f"{kind}: extension missing")
                continue
            major, minor = EGL.EGLint(), EGL.EGLint()
            try:
                ok = EGL.eglInitialize(display, ctypes.pointer(major), ctypes.pointer(minor))
            except EGL.EGLError as exc:  # PyOpenGL raises on EGL_BAD_DISPLAY, EGL_NOT_INITIALIZED
                ok, code = False, f" (EGL error 0x{int(exc.err):x})"
            else:
                code = ""
            if ok:
                return kind, display
            tried.append(f"{kind}: eglInitialize failed{code}")
        raise GLBackendError(f"no display could be initialised ({'; '.join(tried)})",
                             fix=DEBIAN_FIX["egl"])

    def make_current(self) -> None:
        """Make this context current in the calling thread."""
        from OpenGL import EGL

        if self._context is None:
            raise RuntimeError("this EGL context was destroyed")
        if not EGL.eglMakeCurrent(self._display, self._surface, self._surface, self._context):
            raise GLBackendError("eglMakeCurrent failed", fix=DEBIAN_FIX["egl"])

    def destroy(self) -> None:
        """Destroy this context (idempotent); the shared display stays initialised."""
        if self._context is None:
            return
        from OpenGL import EGL

        if _address(EGL.eglGetCurrentContext()) == _address(self._context):
            EGL.eglMakeCurrent(self._display, EGL.EGL_NO_SURFACE, EGL.EGL_NO_SURFACE,
                               EGL.EGL_NO_CONTEXT)
        EGL.eglDestroyContext(self._display, self._context)
        if _address(self._surface):
            EGL.eglDestroySurface(self._display, self._surface)
        self._context = None


def _get_display(kind: str, client: list[bytes]) -> Any | None:
    """An EGL display of ``kind``, or ``None`` where its client extension is missing."""
    from OpenGL import EGL

    platform_base = b"EGL_EXT_platform_base" in client
    if kind == "device":
        if not (platform_base and b"EGL_EXT_platform_device" in client
                and b"EGL_EXT_device_enumeration" in client):
            return None
        from OpenGL.EGL.EXT.device_base import eglQueryDevicesEXT
        from OpenGL.EGL.EXT.platform_base import eglGetPlatformDisplayEXT
        from OpenGL.EGL.EXT.platform_device import EGL_PLATFORM_DEVICE_EXT

        devices = (EGL.EGLDeviceEXT * 1)()
        count = EGL.EGLint()
        if not eglQueryDevicesEXT(1, devices, ctypes.pointer(count)) or count.value < 1:
            return None
        return eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[0], None)
    if kind == "surfaceless":
        if not (platform_base and b"EGL_MESA_platform_surfaceless" in client):
            return None
        from OpenGL.EGL.EXT.platform_base import eglGetPlatformDisplayEXT

        return eglGetPlatformDisplayEXT(_EGL_PLATFORM_SURFACELESS_MESA, EGL.EGL_DEFAULT_DISPLAY,
                                        None)
    return EGL.eglGetDisplay(EGL.EGL_DEFAULT_DISPLAY)


class OSMesaContext:
    """An OSMesa context (core profile :data:`GL_VERSION`) current on a 1 x 1 RGBA buffer.

    The buffer is only what ``OSMesaMakeCurrent`` requires: every pass draws into its own
    framebuffer object.
    """

    def __init__(self) -> None:
        _import_gl("osmesa")
        from OpenGL import GL, arrays

        try:
            from OpenGL.osmesa import (
                OSMESA_CONTEXT_MAJOR_VERSION,
                OSMESA_CONTEXT_MINOR_VERSION,
                OSMESA_CORE_PROFILE,
                OSMESA_FORMAT,
                OSMESA_PROFILE,
                OSMESA_RGBA,
                OSMesaCreateContextAttribs,
            )
        except ImportError as exc:
            import OpenGL

            raise GLBackendError(f"PyOpenGL {OpenGL.__version__} has no "
                                 f"OSMesaCreateContextAttribs ({exc})", fix=PIP_FIX) from exc
        attributes = arrays.GLintArray.asArray([
            OSMESA_FORMAT, OSMESA_RGBA,
            OSMESA_PROFILE, OSMESA_CORE_PROFILE,
            OSMESA_CONTEXT_MAJOR_VERSION, GL_VERSION[0],
            OSMESA_CONTEXT_MINOR_VERSION, GL_VERSION[1],
            0,
        ])
        self._context = OSMesaCreateContextAttribs(attributes, None)
        if not _address(self._context):
            raise GLBackendError(
                f"no OpenGL {GL_VERSION[0]}.{GL_VERSION[1]} core context",
                fix=DEBIAN_FIX["osmesa"])
        self._buffer = arrays.GLubyteArray.zeros((1, 1, 4))
        self._type = GL.GL_UNSIGNED_BYTE
        self.make_current()

    def make_current(self) -> None:
        """Make this context current in the calling thread."""
        from OpenGL.osmesa import OSMesaMakeCurrent

        if self._context is None:
            raise RuntimeError("this OSMesa context was destroyed")
        if not OSMesaMakeCurrent(self._context, self._buffer, self._type, 1, 1):
            raise GLBackendError("OSMesaMakeCurrent failed",
                                 fix=DEBIAN_FIX["osmesa"])

    def destroy(self) -> None:
        """Destroy this context (idempotent)."""
        if self._context is None:
            return
        from OpenGL.osmesa import OSMesaDestroyContext

        OSMesaDestroyContext(self._context)
        self._context = self._buffer = None


def open_context(backend: str) -> EGLContext | OSMesaContext:
    """A new offscreen context of ``backend`` ("egl" or "osmesa"), current in this thread.

    Raises
    ------
    GLBackendError
        Naming what is missing (a Python package, a system library, a display) and the fix.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    return EGLContext() if backend == "egl" else OSMesaContext()
