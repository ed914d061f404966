"""birdocp: trimmed periodic flapping flight of a bird (CasADi model) and its Floquet stability."""

try:  # written by setuptools-scm at build time (pip install . or -e .); read in 0.5 ms
    from birdocp.build_info import __version__
except ImportError:  # a source tree that was never built: the installed metadata, if any (~25 ms)
    try:
        from importlib.metadata import version as _version

        __version__ = _version("birdocp")
    except Exception:  # not installed at all
        __version__ = "0.1.0"
