"""``stereoforge validate``: stress any matcher on controlled axes, score it, report.

- :mod:`synth.validate.properties` — the property battery (hypothesis) and ``properties.json``
- :mod:`synth.validate.report` — the self-contained ``report.html``

Nothing is imported here: each module pulls in what it needs when imported.
"""

__all__: list[str] = []
