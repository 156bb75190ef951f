"""A dataset on disk: where it is written, where its files live, how samples are committed, checked.

- :mod:`synth.dataset.storage.fs` — local folders or fsspec URLs
  (:class:`~synth.dataset.storage.fs.FsPath`), the commit of returned bytes.
- :mod:`synth.dataset.storage.layout` — where sample folders live (``MiddEval3/trainingF/``,
  ``2014/``, ``training/samples/``), the tools' folders, ``records/``, ``--upgrade``.
- :mod:`synth.dataset.storage.commit` — a rendered sample into place: folder rename, completion
  record, returned bytes.
- :mod:`synth.dataset.storage.integrity` — completion records (size and SHA-256 of every file),
  :func:`~synth.dataset.storage.integrity.verify_dataset`.
- :mod:`synth.dataset.storage.manifest` — ``manifest.jsonl`` / ``manifest.csv`` from the samples'
  records.
- :mod:`synth.dataset.storage.shards` — ``--format webdataset``: tar shards, their index, resume.

Nothing is imported here: each is imported from its module.
"""

__all__: list[str] = []
