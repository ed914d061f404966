"""Shared fixtures: the coarse shooting method of the quick tests, the default bird model, and the
reference trim (solved once per test session). Tests over ~5 s carry the ``slow`` marker."""
from __future__ import annotations

import os
import tempfile

import pytest

# internal-error logs of the tests (exit 3) go to a temporary folder, not the user's ~/.local/state
os.environ.setdefault("BIRDOCP_LOG_DIR", os.path.join(tempfile.gettempdir(), "birdocp-test-logs"))

COARSE_METHOD = {"points": 3, "steps_per_period": 48}
"""Shooting points and RK4 steps of the quick bird tests (converges on the reference case; the
multipliers are within ~1e-3 of the fine grid's)."""


@pytest.fixture(scope="session")
def coarse() -> dict:
    """Keyword arguments of a coarse :class:`~birdocp.engine.shooting.OrbitMethod` (a copy per use
    is not needed: treat it as read-only)."""
    return dict(COARSE_METHOD)


@pytest.fixture(scope="session")
def default_config():
    """The paper's reference configuration."""
    from birdocp.bird.config import Config

    return Config()


@pytest.fixture(scope="session")
def default_model(default_config):
    """The bird model of the reference configuration (built once per session, cached by birdocp)."""
    from birdocp.bird.model import get_model

    return get_model(default_config)


@pytest.fixture(scope="session")
def reference_trim(default_config):
    """The reference case trimmed with the default method (converged; asserted here)."""
    from birdocp.studies.trim import trim

    res = trim(default_config)
    assert res.success, res.message
    return res
