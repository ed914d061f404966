"""Random valid configurations near the reference case either solve or fail cleanly with a status."""

import pytest

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from birdocp.bird.config import Config, with_values
from birdocp.studies.trim import trim


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(amplitude=st.floats(30.0, 55.0), root=st.floats(0.02, 0.08), incidence=st.floats(5.0, 18.0),
       u0=st.floats(8.0, 25.0), theta0=st.floats(-0.5, 0.5), solver=st.sampled_from(["ipopt", "lm"]))
@pytest.mark.slow
def test_random_configs_solve_or_fail_cleanly(amplitude, root, incidence, u0, theta0, solver):
    cfg = with_values(Config(), {"gait.shoulder_flap.amplitude_deg": amplitude, "wing.root_ahead_m": root,
                                 "gait.shoulder_incidence.offset_deg": incidence,
                                 "solve.initial_guess": [u0, 0.5, 0.1, theta0], "solve.solver": solver})
    r = trim(cfg, max_iter=40)  # never raises
    assert isinstance(r.success, bool) and isinstance(r.status, str) and r.message
    d = r.to_dict()
    assert d["status"] == r.status
    if r.success:
        assert r.max_residual < (1e-8 if solver == "ipopt" else 1e-4)
        assert np.all(np.isfinite(r.multipliers))
        assert np.all(np.asarray(r.trajectory_x)[:, 0] > 0)
    else:
        assert r.status not in ("Solve_Succeeded", "converged")
