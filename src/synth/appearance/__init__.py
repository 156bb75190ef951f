"""What the views look like beyond geometry: sensor models, texture and textureless areas.

- :mod:`synth.appearance.photometric` — seeded sensor models applied to a pair (blur, gamma,
  gain/bias, noise, JPEG).
- :mod:`synth.appearance.texture_control` — texture frequency, contrast and edge density under
  control.
- :mod:`synth.appearance.textureless` — the textureless share of a view: per-object pixel
  coverage, the target search.

Nothing is imported here (the public names are :mod:`synth`'s): each is imported from its module.
"""

__all__: list[str] = []
