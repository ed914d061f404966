"""``aero.span_subdivisions = k``: every lifting-line element cut into k sub-elements along its node -
centre - node line (same geometry, stepped planform) in the model itself, so that trim, level flight
and the 6-DOF model all see it; 1 (the default) is today's model (tests/test_span_direction.py checks the
committed multiplier)."""
from __future__ import annotations

import numpy as np
import pytest

from birdocp import Config, trim, with_values
from birdocp.bird.config import ConfigError


def _options(k, span="leading_line"):
    return {"aero.span_subdivisions": k, "aero.span_direction": span}


def test_subdivisions_must_be_an_integer_from_one_to_eight_with_the_linear_section():
    assert Config().aero.span_subdivisions == 1
    for bad in (0, 9, 2.5, True):
        with pytest.raises(ConfigError, match="aero.span_subdivisions"):
            with_values(Config(), {"aero.span_subdivisions": bad})
    with pytest.raises(ConfigError, match="aero.span_subdivisions"):
        with_values(Config(), {"aero.span_subdivisions": 2, "aero.unsteady": "wagner"})


@pytest.mark.parametrize("span", ["leading_line", "element"])
def test_the_model_cut_in_two_is_glide_refineds_line(span):
    """Two code paths for the same refined line: the model's data graph with ``k = 2`` (load derivatives
    of its frozen glide) and :mod:`birdocp.studies.glide_refined` (NumPy on the 16-element line, the
    same lifting-line code) agree to round-off, with both span directions."""
    from birdocp.studies.glide import attached_config, load_derivatives_at
    from birdocp.studies.glide_refined import refined_load_derivatives

    cfg = attached_config()
    u, w = 10.25, 0.04
    model = load_derivatives_at(with_values(cfg, _options(2, span)), u, w)
    study = refined_load_derivatives(cfg, u, w, 2, "step", "section" if span == "leading_line" else "element")
    assert study.pop("elements") == 32
    for key, v in model.items():
        assert abs(study[key] - v) <= 1e-10 * max(1.0, abs(v)), (key, study[key], v)


def test_refinement_converges():
    """The trimmed cycle's leading multiplier (coarse grid) with k = 1, 2, 3: the change shrinks with k
    (measured 1 -> 2: 2.4e-3; 2 -> 4: 1.6e-3)."""
    lead = []
    for k in (1, 2, 3):
        r = trim(with_values(Config(), _options(k)), points=3, steps_per_period=48)
        assert r.success
        lead.append(float(np.max(np.abs(r.multipliers))))
    assert abs(lead[2] - lead[1]) < abs(lead[1] - lead[0])
    assert abs(lead[1] - lead[0]) > 1e-4


def test_symmetric_six_dof_cycle_is_the_planar_cycle_with_both_options(coarse):
    from birdocp.engine.method import OrbitMethod
    from birdocp.studies.lateral import lateral_trim

    cfg = with_values(Config(), _options(2, "element"))
    planar = trim(cfg, **coarse)
    res = lateral_trim(cfg, method=OrbitMethod(**coarse))
    assert planar.success and res.success
    assert res.coupling_max < 1e-12
    np.testing.assert_allclose(np.sort_complex(res.longitudinal_multipliers), np.sort_complex(planar.multipliers),
                               rtol=0, atol=1e-9)
