"""birdocp: trimmed periodic flapping flight of a bird (CasADi model) and its Floquet stability."""

try:  # written by setuptools-scm at build time (pip install . or -e .)
    from birdocp.build_info import __version__
except ImportError:  # a source tree that was never built
    __version__ = "0.1.0"
