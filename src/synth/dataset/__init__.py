"""Datasets: configurations, per-sample sampling, the worker engines and the resumable run.

- :mod:`synth.dataset.run` — :func:`run_dataset`, resume, manifests, :func:`render_from_manifest`.
- :mod:`synth.dataset.sample` — one sample: drawn, rendered, degraded, written; the per-sample task.
- :mod:`synth.dataset.parts` — one dataset over several drivers: index ranges and their lock.
- :mod:`synth.dataset.loader` — :class:`StereoDataset`, a dataset directory as a training dataset.
- :mod:`synth.dataset.compare` — two datasets file by file: content or only encoding.
- :mod:`synth.dataset.config` — the TOML/JSON dataset configuration (``parse``), its schema
  (``keys``) and what sample ``i`` draws from it, seeded by ``i`` (``sampling``).
- :mod:`synth.dataset.engine` — the local process pool (fork server) and Ray engines (``tasks``),
  the Ray driver, the fork server's guard and warm-up.
- :mod:`synth.dataset.storage` — folders and fsspec URLs (``fs``), where the sample folders live
  (``layout``), the commit of a sample, completion records (``integrity``), manifests, shards.
- ``configs/`` — the shipped example configurations (``planes``, ``texture-sweep``, ``flying``,
  and the texture-versus-window study).

Names load from their modules on first use (:mod:`synth._util.lazy`):
``synth.dataset.engine.tasks`` alone stays light, for the command line and the worker server.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from synth._util.lazy import lazy_namespace

if TYPE_CHECKING:
    from synth.dataset.config.parse import (
        ConfigError,
        DatasetConfig,
        config_from_dict,
        list_examples,
        load_config,
        loads_config,
    )
    from synth.dataset.engine.tasks import ENGINES
    from synth.dataset.loader import StereoDataset
    from synth.dataset.run import (
        DatasetError,
        DatasetRun,
        SampleError,
        read_manifest,
        render_from_manifest,
        run_dataset,
    )

#: Public name -> the module that defines it.
_EXPORTS = {
    "ConfigError": "synth.dataset.config.parse",
    "DatasetConfig": "synth.dataset.config.parse",
    "DatasetError": "synth.dataset.run",
    "DatasetRun": "synth.dataset.run",
    "ENGINES": "synth.dataset.engine.tasks",
    "SampleError": "synth.dataset.run",
    "StereoDataset": "synth.dataset.loader",
    "config_from_dict": "synth.dataset.config.parse",
    "list_examples": "synth.dataset.config.parse",
    "load_config": "synth.dataset.config.parse",
    "loads_config": "synth.dataset.config.parse",
    "read_manifest": "synth.dataset.run",
    "render_from_manifest": "synth.dataset.run",
    "run_dataset": "synth.dataset.run",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, globals())
