"""A rendered pair on disk: the layouts, the files, previews and optional ground truth.

- :mod:`synth.write.export` — one pair on disk: its layout's files (:mod:`synth.formats`),
  ``scene.json``, ``preview.png``.
- :mod:`synth.write.extra_ground_truth` — optional ground truth: depth, normals, instance and semantic
  masks, the right view's mask.
- :mod:`synth.write.preview` — colour-mapped disparity with a colour bar, the demo contact sheet.

Nothing is imported here (the public names are :mod:`synth`'s): each is imported from its module,
so the command line reads :mod:`synth.formats` without importing the writers.
"""

__all__: list[str] = []
