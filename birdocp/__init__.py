"""birdocp: trimmed periodic flapping flight of a bird (CasADi model) and its Floquet stability.

The names a user needs are importable from the package itself (``from birdocp import Config, trim``);
they are loaded on first use (PEP 562), so ``import birdocp`` and the command line's start-up stay as
fast as the package's version lookup. The engine for periodic orbits of any ODE has its own face,
:mod:`birdocp.engine`.

Examples
--------
>>> import birdocp
>>> cfg = birdocp.with_values(birdocp.Config(), {"gait.shoulder_flap.amplitude_deg": 43.0})
>>> cfg.gait.shoulder_flap.amplitude_deg
43.0
"""

try:  # written by setuptools-scm at build time (pip install . or -e .); read in 0.5 ms
    from birdocp.build_info import __version__
except ImportError:  # a source tree that was never built: the installed metadata, if any (~25 ms)
    try:
        from importlib.metadata import version as _version

        __version__ = _version("birdocp")
    except Exception:  # not installed at all
        __version__ = "0.1.0"

# The public names, by topic: name -> "module" or "module:attribute" (an alias). Strings, resolved at
# attribute access, so importing the package imports no layer; tests/test_architecture.py checks that
# every target exists and that no target is in the command-line layer.
API = {
    "configuration": {
        "Config": "birdocp.bird.config", "ConfigError": "birdocp.io.errors",
        "with_values": "birdocp.bird.config", "set_value": "birdocp.bird.config",
        "load_config": "birdocp.bird.config:load", "dump_config": "birdocp.bird.config:dump",
    },
    "model": {"BirdModel": "birdocp.bird.model", "get_model": "birdocp.bird.model"},
    "trim": {"trim": "birdocp.studies.trim", "TrimResult": "birdocp.studies.trim"},
    "level flight": {"level": "birdocp.studies.level"},
    "sweeps": {"sweep": "birdocp.studies.sweep", "grid_sweep": "birdocp.studies.sweep"},
    "continuation": {"bird_branch": "birdocp.studies.branch"},
    "sensitivity": {"multiplier_sensitivities": "birdocp.studies.sensitivity",
                    "SensitivityResult": "birdocp.studies.sensitivity"},
    "optimisers": {"optimize_stability": "birdocp.studies.optimize", "StabilityOptimum": "birdocp.studies.optimize",
                   "optimize_gait": "birdocp.studies.gait", "GaitOptimum": "birdocp.studies.gait",
                   "power_curve": "birdocp.studies.power_curves", "stability_pareto": "birdocp.studies.gait_fronts"},
    "control": {"design_controller": "birdocp.studies.control", "Controller": "birdocp.studies.control",
                "wingbeat_map": "birdocp.studies.control"},
    "simulation": {"simulate": "birdocp.studies.simulate", "SimulationResult": "birdocp.studies.simulate",
                   "Gust": "birdocp.studies.simulate_inputs", "gust_envelope": "birdocp.studies.simulate"},
    "six degrees of freedom": {"lateral_trim": "birdocp.studies.lateral", "LateralTrimResult": "birdocp.studies.lateral",
                               "lateral_sensitivities": "birdocp.studies.lateral_sensitivity",
                               "design_lateral_controller": "birdocp.studies.lateral_control",
                               "simulate_lateral": "birdocp.studies.lateral_simulate",
                               "SideGust": "birdocp.studies.lateral_simulate"},
    "validity": {"cycle_validity": "birdocp.bird.validity", "periodic_validity": "birdocp.bird.validity",
                 "CycleValidity": "birdocp.bird.validity"},
    "export": {"export_c": "birdocp.export.codegen", "compiled_ode": "birdocp.export.compiled"},
}
_TARGETS = {name: target for group in API.values() for name, target in group.items()}
__all__ = ["__version__", *_TARGETS]


def __getattr__(name: str):
    """Import a public name's module on first access (PEP 562) and keep the name."""
    target = _TARGETS.get(name)
    if target is None:
        raise AttributeError(f"module 'birdocp' has no attribute {name!r}")
    import importlib

    module, _, attr = target.partition(":")
    value = getattr(importlib.import_module(module), attr or name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_TARGETS))
