"""matcher package."""

__all__: list[str] = []
