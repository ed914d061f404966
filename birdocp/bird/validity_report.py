"""How a validity verdict is written (:mod:`birdocp.bird.validity`): one line for tables and messages,
and the flat columns of a sweep's table.

Split from :mod:`birdocp.bird.validity` (which re-exports every name here) to keep modules small.
"""

from __future__ import annotations

__all__ = ["validity_text", "VALIDITY_COLUMNS", "validity_columns"]


def validity_text(v: dict | None) -> str:
    """One line for a ``validity`` dict (:meth:`CycleValidity.to_dict`): the verdict and the reasons,
    or the key numbers when valid.

    Parameters
    ----------
    v : dict or None
        Validity dict.

    Returns
    -------
    str
    """
    if not v:
        return "not checked"
    if not v.get("valid"):
        return "NOT VALID: " + "; ".join(v.get("reasons") or ["(no reason given)"])
    try:
        return ("valid (effective angle of attack {:.1f}..{:.1f} deg, {:.1%} of span-time beyond stall, "
                "min u {:.2f} m/s, theta {:.1f}..{:.1f} deg, airflow-body angle <= {:.1f} deg)").format(
            v["alpha_eff_min_deg"], v["alpha_eff_max_deg"], v["stalled_fraction"], v["min_forward_speed_mps"],
            v["pitch_min_deg"], v["pitch_max_deg"], v["max_airflow_body_angle_deg"])
    except (KeyError, TypeError, ValueError):
        return "valid"


VALIDITY_COLUMNS = ("valid", "invalid_reasons", "stalled_fraction", "alpha_eff_max_abs_deg",
                    "min_forward_speed_mps_in_cycle", "max_abs_pitch_deg", "max_airflow_body_angle_deg")
"""Columns of a table row (sweeps, branches) taken from a ``validity`` dict by :func:`validity_columns`."""


def validity_columns(v: dict | None) -> dict:
    """The flat table columns :data:`VALIDITY_COLUMNS` of a ``validity`` dict (``to_dict()``).

    Parameters
    ----------
    v : dict or None
        Validity dict.

    Returns
    -------
    dict
    """
    v = v or {}
    amin, amax = v.get("alpha_eff_min_deg"), v.get("alpha_eff_max_deg")
    return {"valid": v.get("valid"), "invalid_reasons": " | ".join(v.get("reasons") or []) or None,
            "stalled_fraction": v.get("stalled_fraction"),
            "alpha_eff_max_abs_deg": max(abs(amin), abs(amax)) if amin is not None and amax is not None else None,
            "min_forward_speed_mps_in_cycle": v.get("min_forward_speed_mps"),
            "max_abs_pitch_deg": v.get("max_abs_pitch_deg"),
            "max_airflow_body_angle_deg": v.get("max_airflow_body_angle_deg")}
