"""Where the samples of a run are computed: the local process pool and Ray, one renderer per worker.

- :mod:`synth.dataset.engine.tasks` — :func:`~synth.dataset.engine.tasks.run_tasks` over the
  ``local`` (fork server) and ``ray`` engines, the worker set-up and lifetime.
- :mod:`synth.dataset.engine.ray_driver` — the Ray driver: Ray imported on the loopback, actors
  scheduled one task each, lost ones replaced.
- :mod:`synth.dataset.engine.guard` — first import of the fork server: it dies with the main
  process.
- :mod:`synth.dataset.engine.warm` — what a worker server runs once before forking workers.

Nothing is imported here: :mod:`synth.dataset.engine.tasks` alone stays light, for the command
line and the worker server.
"""

__all__: list[str] = []
