"""A mix of dataset configurations: each sample drawn from one of them.

A configuration whose top level holds ``mix = ["floating", "dense", "outdoor"]`` (shipped
example names, ``.toml`` paths, relative to the configuration's folder or the working
directory, or inline tables as :meth:`DatasetConfig.to_dict` writes them) has no ``[rig]``,
``[scene]`` or ``[photometric]`` of its own: sample ``i`` picks part
``SeedSequence(sample_seed, spawn_key=(10,))``'s integer in ``[0, len(mix))`` (each part
equally likely; name one twice to weight it) and is then that part's sample ``i`` under the
mix's seed, drawn exactly as the part draws it. Every part renders the same image size; the
mix's ``redraw``, ``preview``, ``ground_truth`` and ``image_deflate`` apply to all of them
(the parts' own are ignored), and a part may not be a mix. A sample's params name its part
(``mix.part``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

from stereoforge.errors import ConfigError
from synth.dataset.config.keys import EXAMPLES, SCHEMA

#: A parsed part (a ``synth.dataset.config.parse.DatasetConfig``; not imported: parse imports
#: this module).
DatasetConfig = Any

__all__ = ["load_parts", "STREAM_MIX"]

#: The sample-seed stream that picks a mix's part (``sampling.pick_part``).
STREAM_MIX = 10


def _part(item: Any, i: int, source: str, load: Callable[[Any], DatasetConfig],
          from_dict: Callable[..., DatasetConfig]) -> DatasetConfig:
    where = f"{source}: mix[{i}]"
    if isinstance(item, dict):
        return from_dict(item, source=where)
    if not isinstance(item, str) or not item:
        raise ConfigError(f"{where}: expected a configuration name, a .toml path or a table, "
                          f"got {item!r}")
    if item in EXAMPLES:
        return load(item)
    path = Path(item)
    beside = Path(source).parent / path
    if not path.is_absolute() and source not in ("<string>", "<dict>") and beside.is_file():
        path = beside  # relative to the mix's own file first
    return load(path)


def load_parts(value: Any, source: str, *, load: Callable[[Any], DatasetConfig],
               from_dict: Callable[..., DatasetConfig]) -> tuple[DatasetConfig, ...]:
    """The parts of a ``mix`` value (see the module docstring), checked: a non-empty array,
    no nested mix, one image size. ``load`` and ``from_dict`` read a part (the parser's
    ``load_config`` and ``config_from_dict``)."""
    if not isinstance(value, list) or not value:
        raise ConfigError(f"{source}: mix: expected a non-empty array of configuration names, "
                          f".toml paths or tables, got {value!r}")
    # a part's count means nothing in a mix: the default, so that a mix equals its round trip
    parts = tuple(dataclasses.replace(_part(item, i, source, load, from_dict),
                                      count=SCHEMA[""]["count"].default)
                  for i, item in enumerate(value))
    for i, part in enumerate(parts):
        if part.parts:
            raise ConfigError(f"{source}: mix[{i}]: {part.name!r} is a mix itself; name its "
                              "parts instead")
    sizes = sorted({(p.rig.width, p.rig.height) for p in parts})
    if len(sizes) > 1:
        raise ConfigError(f"{source}: mix: every part renders one image size, got "
                          f"{', '.join(f'{w}x{h}' for w, h in sizes)}; give them the same "
                          "[rig] width and height (or run the mix with --size)")
    return parts
