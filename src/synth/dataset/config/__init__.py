"""What a dataset is: its configuration file, every key of it, and what sample ``i`` draws.

- :mod:`synth.dataset.config.parse` — the configuration (TOML/JSON): the parser,
  :class:`~synth.dataset.config.parse.DatasetConfig`.
- :mod:`synth.dataset.config.dists` — one parameter's distribution (:class:`Dist`).
- :mod:`synth.dataset.config.keys` — every key of a configuration: sections, types, bounds, docs
  (the schema).
- :mod:`synth.dataset.config.sampling` — what sample ``i`` draws (seeded by ``i``): the sample
  seed, the drawn parameters and the scene.
- :mod:`synth.dataset.config.rig_draws` — the ``[rig]`` keys drawn per sample.

The shipped configurations are the TOML files of ``synth/dataset/configs/`` (data, beside this
package). Nothing is imported here (the public names are :mod:`synth.dataset`'s).
"""

__all__: list[str] = []
