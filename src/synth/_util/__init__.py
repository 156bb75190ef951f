"""Helpers the rest of :mod:`synth` shares (private: not part of the API).

- :mod:`synth._util.json_records` — JSON records read strictly (dataset.json, sample.json,
  manifests, golden manifest): a damaged or foreign file is one clear error.
- :mod:`synth._util.toml_lines` — where each key of a TOML document sits (``file:line`` of
  configuration errors), TOML reading.
- :mod:`synth._util.lazy` — lazy package namespaces (PEP 562) for ``synth`` and ``synth.dataset``.
- :mod:`synth._util.kernel_cache` — is numba's cache cold? The one-off "compiling kernels" notice.
- :mod:`synth._util.progress` — progress bars: live on a terminal, plain lines in a log file.

Nothing is imported here: each helper is imported from its module.
"""

__all__: list[str] = []
