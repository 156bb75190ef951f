"""Imported first by the fork server of :mod:`synth.dataset.engine.tasks`: the server ends with the
process that started it (``kill -9`` of that process, the OOM killer, a CI timeout), and the
workers it forked end with it (they call :func:`~synth.dataset.engine.tasks.die_with_parent` too).

Without it the server and its workers outlive a killed main process, still rendering samples
without holding the dataset's lock. No watchdog thread here: the server forks, and forking a
multi-threaded process is unsafe. Nothing else should import it.
"""

from __future__ import annotations

from synth.dataset.engine.tasks import die_with_parent

__all__: list[str] = []

die_with_parent(watchdog=False)
