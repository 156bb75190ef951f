"""The only GL code of stereoforge: backend choice, offscreen contexts, the render passes.

- :mod:`synth.render.backend` — which GL platform (EGL, OSMesa) this process uses, probed in a
  subprocess before anything imports OpenGL; llvmpipe's rasterizer threads.
- :mod:`synth.render.meshes` — scene -> vertex arrays and textures, depth-range checks (no GL).
- :mod:`synth.render.renderer` — :class:`Renderer`: one context, the colour pass and the exact
  float depth pass.

Importing this package imports no OpenGL: PyOpenGL is loaded by the first :class:`Renderer`.
"""

from synth.render.backend import BACKENDS, GLBackendError, resolve_backend
from synth.render.renderer import Renderer, ViewRender

__all__ = ["BACKENDS", "GLBackendError", "Renderer", "ViewRender", "resolve_backend"]
