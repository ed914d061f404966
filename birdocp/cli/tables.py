"""The command line's text output: numbers, the trim table and the validity column of the tables.

Part of :mod:`birdocp.cli.common` (which re-exports these names for the command modules).
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["one_line", "fmt_num", "real_part", "pairs", "growth_text", "format_trim_table", "validity_word",
           "validity_notes"]


def one_line(text: Any) -> str:
    """``text`` on one line (runs of white space as one space).

    Parameters
    ----------
    text : Any
        Text or value (``str`` of it).

    Returns
    -------
    str
    """
    return " ".join(str(text).split())


def fmt_num(x: Any, fmt: str = ".6g") -> str:
    """A number for a table: "-" for None, ``re + imj`` for a [re, im] pair, ``str`` of a non-number.

    Parameters
    ----------
    x : Any
        Value to format.
    fmt : str
        Format specification of the number(s).

    Returns
    -------
    str
    """
    if x is None:
        return "-"
    if isinstance(x, (list, tuple)) and len(x) == 2:
        re_, im = x
        return f"{fmt_num(re_, fmt)} {'-' if (im or 0) < 0 else '+'} {fmt_num(abs(im or 0), fmt)}j"
    try:
        return format(float(x), fmt)
    except (TypeError, ValueError):
        return str(x)


def real_part(x: Any) -> float | None:
    """The real part of a value as a float: the first item of a [re, im] pair; None if not a number.

    Parameters
    ----------
    x : Any
        Value, pair or None.

    Returns
    -------
    float or None
    """
    if x is None:
        return None
    if isinstance(x, (list, tuple)):
        x = x[0] if x else None
        if x is None:
            return None
    try:
        return float(x)
    except (TypeError, ValueError):
        return None


def pairs(values: Any) -> list:
    """``values`` as a list when it is a list or tuple, else an empty list.

    Parameters
    ----------
    values : Any
        Value of a result key.

    Returns
    -------
    list
    """
    return list(values) if isinstance(values, (list, tuple)) else []


def growth_text(exponent: Any, doubling: Any) -> str:
    """'doubles in 0.3 s' / 'halves in 1.2 s' / 'neutral'.

    Parameters
    ----------
    exponent : float or [re, im] or None
        Floquet exponent [1/s] (its real part is the growth rate).
    doubling : float or [re, im] or None
        Doubling time [s] (negative: halving time); used when finite and non-zero.

    Returns
    -------
    str
    """
    rate = real_part(exponent)
    t = real_part(doubling)
    if t is not None and math.isfinite(t) and t != 0:
        sign = 1 if (rate is None and t > 0) or (rate is not None and rate > 0) else -1
        return f"{'doubles' if sign > 0 else 'halves'} in {abs(t):.4g} s"
    if rate is not None and rate != 0 and math.isfinite(rate):
        from birdocp.engine.floquet import doubling_time_s

        return f"{'doubles' if rate > 0 else 'halves'} in {abs(doubling_time_s(rate)):.4g} s"
    return "neutral"


def _multiplier_lines(r: dict) -> list[str]:
    """The Floquet-multiplier block of :func:`format_trim_table` (none without multipliers)."""
    lines = []
    mults = pairs(r.get("multipliers"))
    if mults:
        moduli = pairs(r.get("moduli"))
        exps = pairs(r.get("floquet_exponents", r.get("floquet_exponents_per_s")))
        dts = pairs(r.get("doubling_times_s"))
        lines.append("")
        lines.append("Floquet multipliers (largest modulus first)")
        header = f"  {'#':>2}  {'re':>12}  {'im':>12}  {'modulus':>10}  {'exponent [1/s]':>24}  growth"
        lines.append(header)
        for i, m in enumerate(mults):
            re_, im = (m[0], m[1]) if isinstance(m, (list, tuple)) and len(m) == 2 else (m, 0.0)
            mod = moduli[i] if i < len(moduli) else (math.hypot(re_ or 0, im or 0) if re_ is not None else None)
            ex = exps[i] if i < len(exps) else None
            dt = dts[i] if i < len(dts) else None
            lines.append(f"  {i:>2}  {fmt_num(re_):>12}  {fmt_num(im):>12}  {fmt_num(mod, '.6f'):>10}  "
                         f"{fmt_num(ex):>24}  {growth_text(ex, dt)}")
    return lines


def format_trim_table(r: dict) -> str:
    """The human-readable table of a trim or level result: status, residual, multipliers with their
    growth and the cycle's validity.

    Parameters
    ----------
    r : dict
        JSON-able result of ``trim`` or ``level``.

    Returns
    -------
    str
        Lines joined by newlines.
    """
    from birdocp.bird.validity import validity_text

    lines = []
    ok = bool(r.get("success"))
    lines.append(f"trim: {'converged' if ok else 'NOT converged'} (status: {r.get('status')})")
    if r.get("message"):
        lines.append(f"  {one_line(r['message'])}")
    lines += _multiplier_lines(r)
    lines.append("")
    stable = r.get("stable")
    verdict = "stable" if stable is True else "unstable" if stable is False else "unknown"
    rows = [
        ("verdict", verdict),
        ("model validity", validity_text(r.get("validity"))),
        ("mean forward speed", f"{fmt_num(r.get('mean_forward_speed_mps'), '.4f')} m/s"),
        ("mean vertical speed", f"{fmt_num(r.get('mean_vertical_speed_mps'), '.4f')} m/s"),
        ("flight path angle", f"{fmt_num(r.get('flight_path_angle_deg'), '.4f')} deg"),
    ]
    if (r.get("wing_mass_kg") or 0) > 0:
        rows.append(("wing mass (each)", f"{fmt_num(r.get('wing_mass_kg'), '.4g')} kg"))
        rows.append(("inertial power", f"dT_rel/dt mean {fmt_num(r.get('mean_inertial_power_W'), '+.3g')} W, "
                                       f"positive part {fmt_num(r.get('mean_positive_inertial_power_W'), '.4g')} W, "
                                       f"peak {fmt_num(r.get('peak_inertial_power_W'), '.4g')} W"))
        rows.append(("shoulder inertial power", f"mean {fmt_num(r.get('mean_shoulder_inertial_power_W'), '+.4g')} W"))
    x0 = r.get("x0")
    if isinstance(x0, (list, tuple)) and len(x0) == 4:
        u, w, q, th = x0
        rows.append(("x0 (u, w, q, theta)", f"{fmt_num(u, '.6g')} m/s, {fmt_num(w, '.6g')} m/s, "
                                              f"{fmt_num(q, '.6g')} rad/s, {fmt_num(th, '.6g')} rad"))
    if r.get("mean_aerodynamic_power_W") is not None:
        rows += [
            ("mean aerodynamic power", f"{fmt_num(r.get('mean_aerodynamic_power_W'), '.4f')} W "
                                       f"(induced {fmt_num(r.get('mean_induced_power_W'), '.4f')} W)"),
            ("mean shoulder power", f"{fmt_num(r.get('mean_shoulder_power_W'), '.4f')} W "
                                    f"(body {fmt_num(r.get('mean_body_power_W'), '.4f')} W)"),
            ("mean positive power", f"{fmt_num(r.get('mean_positive_power_W'), '.4f')} W (no negative-work storage)"),
            ("cost of transport", f"{fmt_num(r.get('cost_of_transport'), '.4f')} "
                                  f"(positive work {fmt_num(r.get('cost_of_transport_positive'), '.4f')})"),
            ("Strouhal number", f"{fmt_num(r.get('strouhal_number'), '.4f')} "
                                f"(f A / U, tip excursion {fmt_num(r.get('wingtip_excursion_m'), '.4f')} m)"),
            ("reduced frequency", f"{fmt_num(r.get('reduced_frequency'), '.4f')} (pi f c / U), "
                                  f"span-based {fmt_num(r.get('reduced_frequency_span'), '.4f')}"),
        ]
    rows.append(("iterations", str(r.get("iterations", "-"))))
    rows.append(("max residual", fmt_num(r.get("max_residual"), ".3e")))
    sp = r.get("shooting_points")
    if isinstance(sp, int) or (isinstance(sp, (list, tuple)) and sp):
        rows.append(("shooting points", str(sp if isinstance(sp, int) else len(sp))))
    wall = r.get("wall_s")
    if isinstance(wall, dict):
        total = wall.get("total")
        phases = ", ".join(f"{k} {fmt_num(v, '.3g')}" for k, v in wall.items() if k != "total")
        rows.append(("wall time", f"{fmt_num(total, '.3g')} s" + (f" ({phases})" if phases else "")))
    elif wall is not None:
        rows.append(("wall time", f"{fmt_num(wall, '.3g')} s"))
    if r.get("run_dir"):
        rows.append(("run folder", str(r["run_dir"])))
    width = max(len(k) for k, _ in rows)
    lines += [f"{k:<{width}}  {v}" for k, v in rows]
    return "\n".join(lines)


def validity_word(valid) -> str:
    """The model-validity column of a table: ``valid``, ``INVALID`` or ``-`` (not checked).

    Parameters
    ----------
    valid : bool or None
        The verdict (None: not checked).

    Returns
    -------
    str
    """
    return "valid" if valid is True else "INVALID" if valid is False else "-"


def validity_notes(rows: list[dict], label: str = "value") -> list[str]:
    """Lines naming each invalid point of a table and why (rows with ``validity`` or ``invalid_reasons``).

    Parameters
    ----------
    rows : list of dict
        Rows of the table.
    label : str
        Key of the row's value, named in each line.

    Returns
    -------
    list of str
    """
    out = []
    for r in rows:
        if r.get("valid") is False:
            reasons = (r.get("validity") or {}).get("reasons") or [r.get("invalid_reasons") or "?"]
            out.append(f"  {label} {fmt_num(r.get(label), 'g')}: NOT VALID: {'; '.join(reasons)}")
    if out:
        out.insert(0, "model validity (birdocp.bird.validity; thresholds in [validity]):")
    return out
