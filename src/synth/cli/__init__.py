"""The ``stereoforge`` command line: a thin click layer, one module per command family.

Every subcommand parses its options (shared ones are defined once, in :mod:`synth.cli.options`)
and calls one library function. Errors are reported once, by the group (:mod:`synth.cli.errors`):
one ``Error: ...`` line, exit status 2 for bad input, 1 for a bad environment, a traceback only
with ``stereoforge --debug``. Nothing in the library imports this package.

- :mod:`synth.cli.rendering` — ``presets``, ``render``, ``demo``
- :mod:`synth.cli.datasets` — ``dataset``
- :mod:`synth.cli.matching` — ``match``, ``eval``, ``eval-dataset``
- :mod:`synth.cli.jobs` — ``paper``, ``study``, ``golden``
- :mod:`synth.cli.validating` — ``validate``
- :mod:`synth.cli.learning` — ``train``
- :mod:`synth.cli.bench` — ``bench render|match|paper|dataset|validate``
"""

from __future__ import annotations

import sys

import click

from synth.cli.bench import bench
from synth.cli.datasets import dataset
from synth.cli.errors import BoundaryGroup, set_debug
from synth.cli.jobs import golden, paper, study
from synth.cli.learning import train_cmd
from synth.cli.matching import eval_cmd, eval_dataset_cmd, match_cmd
from synth.cli.rendering import demo, presets, render
from synth.cli.validating import validate

__all__ = ["main"]


@click.group(cls=BoundaryGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="stereoforge")
@click.option("--debug", is_flag=True, expose_value=False, is_eager=True, callback=set_debug,
              help="Show the Python traceback of an error instead of one 'Error:' line.")
def main() -> None:
    """stereoforge: labelled stereo data with exact ground truth, and census matchers."""


for _command in (bench, dataset, demo, eval_cmd, eval_dataset_cmd, golden, match_cmd, paper, presets, render, study,
                 train_cmd, validate):
    main.add_command(_command)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
