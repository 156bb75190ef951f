"""``--format webdataset``: the samples packed in tar shards, in WebDataset's naming.

A sample is written as a MiddEval3 scene folder into ``.staging/NNNNNN/`` and packed into the next
shard in index order (:mod:`synth.dataset.storage.shards`); the shards are read by
``webdataset.WebDataset``, not sample by sample from folders.
"""

from __future__ import annotations

from synth.formats.base import Capacity
from synth.formats.middlebury import MiddleburyLayout

__all__ = ["WebDatasetLayout", "LAYOUT"]


class WebDatasetLayout(MiddleburyLayout):
    """Tar shards of MiddEval3 sample folders."""

    name = "webdataset"
    title = "WebDataset shards"
    capacity = Capacity(right_disparity=True, flow=True, extra_ground_truth=True,
                        sample_folders=False)
    tools_root = ".staging"
    sample_parent = ".staging"
    spec_form = None  # shards are not read sample by sample

    def recognises(self, root) -> bool:
        return False

    @property
    def writes_as(self) -> str:
        return "middlebury"

    def finish_files(self, names: list[str]) -> dict[str, bytes]:
        return {}

    def key(self, index: int) -> str:
        raise NotImplementedError("webdataset shards are read with webdataset.WebDataset")


LAYOUT = WebDatasetLayout()
