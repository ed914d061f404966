"""birdocp: trimmed periodic flapping flight of a bird (CasADi model) and its Floquet stability."""

__version__ = "0.1.0"
"""Fallback version (keep equal to pyproject.toml); the installed metadata wins when present."""
