"""Dataset writers and readers."""

__all__: list[str] = []
