"""The six-degree-of-freedom path of ``trim`` and ``level`` (``model.degrees_of_freedom = 6``): one
run folder with the 9-state cycle, every multiplier and the lateral modes (not a command itself)."""

from __future__ import annotations

import argparse
import time

from birdocp.cli.common import EXIT_OK, fmt_num, finish_result, format_trim_table, run_folder
from birdocp.bird.validity import validity_text
from birdocp.io.errors import ConfigError

def level_options(kw: dict) -> dict:
    """The 6-DOF level options from the planar level's checked keywords: the amplitude solved for a
    mean vertical speed (other free keys and conditions are refused, one line;
    :func:`birdocp.studies.lateral.level_keywords`).

    Parameters
    ----------
    kw : dict
        Checked keywords of the planar level (:func:`birdocp.cli.level.level_kwargs`).

    Returns
    -------
    dict
    """
    from birdocp.studies.lateral_options import level_keywords

    return level_keywords(kw)


def _format_lateral_table(r: dict) -> str:
    """The lateral part of a 6-DOF result: the split, the heading multiplier and the labelled modes."""
    lines = ["", "six degrees of freedom: state (u, v, w, p, q, r, phi, theta, psi)",
             f"  heading multiplier {fmt_num(r.get('heading_multiplier'), '.12g')} (psi: reported apart, "
             "not a stability mode)",
             f"  longitudinal-lateral coupling in the monodromy: max {fmt_num(r.get('coupling_max'), '.2e')}",
             f"  lateral verdict: {_verdict(r.get('lateral_stable'))}"
             + ("" if r.get("symmetric", True) else
                f"\n  asymmetric gait: periodic up to its heading, which changes by "
                f"{fmt_num(r.get('heading_change_deg'), '.6g')} deg per beat (a turn); the 8 multipliers without "
                "psi and the heading's 1 above; no block split: the modes are lateral when at least half of "
                "their scaled eigenvector lies in (v, p, r, phi) (lateral_share)"),
             "  lateral modes (beats: wingbeats to double, negative: to halve)",
             f"    {'label':<17} {'re':>12} {'im':>12} {'modulus':>10} {'beats':>10}  dominant"]
    for m in r.get("lateral_modes") or []:
        re_, im = m["multiplier"] if isinstance(m["multiplier"], (list, tuple)) else (m["multiplier"], 0.0)
        mod = (re_ ** 2 + im ** 2) ** 0.5
        lines.append(f"    {m['label']:<17} {fmt_num(re_):>12} {fmt_num(im):>12} {fmt_num(mod, '.6f'):>10} "
                     f"{fmt_num(m.get('beats_to_double'), '.4g'):>10}  {m.get('dominant_state')}"
                     + (f"  lateral share {m['lateral_share']:.3f}" if "lateral_share" in m else ""))
    return "\n".join(lines)


def _verdict(stable) -> str:
    return "stable" if stable is True else "unstable" if stable is False else "unknown"


def run_six_dof(args: argparse.Namespace, command: str, command_line: list[str], cfg, options: dict) -> int:
    """Solve ``cfg`` in six degrees of freedom (``options``: :func:`birdocp.studies.lateral.lateral_trim`
    keywords), write the run folder, print the table or the JSON; the exit code.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments.
    command : str
        Name of the command.
    command_line : list of str
        The command line, recorded in the provenance.
    cfg : Config
        Resolved configuration.
    options : dict
        Keywords of the six-degree-of-freedom trim.

    Returns
    -------
    int
        Exit code.
    """
    t_start = time.perf_counter()
    with run_folder(args, command, command_line) as run:
        with run.solving():
            from birdocp.studies.lateral import lateral_trim

            res = lateral_trim(cfg, **options)
            result = res.to_dict()
            c = res.cycle
            arrays = {"trajectory_t": c.trajectory_t, "trajectory_x": c.trajectory_x} \
                if c.trajectory_x is not None else None
        for k in ("trajectory_t", "trajectory_x"):
            result.pop(k, None)
        finish_result(result, command, t_start, run.dir)
        run.write(cfg, result, arrays)
        head = ""
        if options.get("level"):
            head = (f"level flight: amplitude A = {fmt_num(res.amplitude_deg, '.6f')} deg "
                    f"(mean vertical_speed_mps = {fmt_num(options.get('climb_rate_mps', 0.0), 'g')})\n")
        table = format_trim_table(result)
        if command != "trim":
            table = table.replace("trim:", f"{command}:", 1)
        run.output(result, head + table + "\n" + _format_lateral_table(result))
        if not res.success:
            return run.fail(f"{command} did not converge", c.status, c.max_residual, c.message)
    return EXIT_OK


def _sensitivity_keys(raw) -> list[str] | None:
    """The checked ``--param`` keys of a 6-DOF sensitivity: model parameters, aliases, the lateral
    inertias (:data:`birdocp.bird.sixdof.LATERAL_PARAM_NAMES`) or the per-side offsets
    (:data:`birdocp.bird.sides.SIDE_PARAM_NAMES`, ``gait.right_offset.<joint>.<field>`` and
    ``gait.left_offset.<joint>.<field>``)."""
    from birdocp.bird.keys import resolve_key
    from birdocp.bird.sides import SIDE_PARAM_NAMES
    from birdocp.bird.sixdof import LATERAL_PARAM_NAMES

    own = set(LATERAL_PARAM_NAMES) | set(SIDE_PARAM_NAMES)
    keys = [k if k in own else _resolve_six_key(k, resolve_key) for k in raw or []]
    return list(dict.fromkeys(keys)) or None


def _resolve_six_key(key: str, resolve_key) -> str:
    """``resolve_key`` of a planar key; a misspelt per-side key gets its own one-line error."""
    from birdocp.bird.config import suggest
    from birdocp.bird.sides import SIDE_PARAM_NAMES

    if ".right_offset." in key or ".left_offset." in key:
        raise ConfigError("--param", f"unknown per-side key '{key}'" + suggest(key, list(SIDE_PARAM_NAMES))
                          + " (gait.right_offset.<joint>.<offset_deg|amplitude_deg|phase_deg>, or left_offset)")
    return resolve_key(key, "--param")


def run_six_dof_sensitivity(args: argparse.Namespace, command_line: list[str], cfg, t_start: float) -> int:
    """``birdocp sensitivity`` with ``model.degrees_of_freedom = 6``: the exact derivatives of every
    multiplier of the 6-DOF cycle at fixed amplitude (:func:`birdocp.studies.lateral_sensitivity.lateral_sensitivities`),
    one row per parameter with the derivative of each lateral mode's modulus; the exit code.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments (``param``).
    command_line : list of str
        The command line, recorded in the provenance.
    cfg : Config
        Resolved configuration.
    t_start : float
        ``time.perf_counter()`` at the start of the command [s].

    Returns
    -------
    int
        Exit code.
    """
    params = _sensitivity_keys(args.param)
    if args.level:
        raise ConfigError("--level", "with model.degrees_of_freedom = 6 the sensitivities are taken at fixed "
                                     "amplitude: solve 'birdocp level' and set gait.shoulder_flap.amplitude_deg "
                                     "to its amplitude (drop --level)")
    if args.top < 1:
        raise ConfigError("--top", f"must be >= 1, got {args.top}")
    with run_folder(args, "sensitivity", command_line) as run:
        with run.solving():
            from birdocp.studies.lateral import lateral_trim
            from birdocp.studies.lateral_sensitivity import lateral_sensitivities

            base = lateral_trim(cfg)
        result = base.to_dict()
        for k in ("trajectory_t", "trajectory_x"):
            result.pop(k, None)
        if not base.success:
            finish_result(result, "sensitivity", t_start, run.dir)
            run.write(cfg, result)
            run.output(result, None)
            return run.fail("sensitivity: the 6-DOF cycle did not converge", base.cycle.status,
                            base.cycle.max_residual, base.cycle.message)
        with run.solving():
            rows = lateral_sensitivities(base, cfg, params)
        result["sensitivities"] = [_sensitivity_row(r) for r in rows]
        result["sensitivity_labels"] = rows[0]["labels"] if rows else []
        finish_result(result, "sensitivity", t_start, run.dir)
        run.write(cfg, result)
        run.output(result, _sensitivity_table(result, args.top))
    return EXIT_OK


def _sensitivity_row(r: dict) -> dict:
    """One parameter's row: d|Lambda| per multiplier (in the order of ``sensitivity_labels``), the
    derivatives of the multipliers as [re, im] and, per mode label, one d|Lambda| (a pair shares it)."""
    by_label: dict = {}
    for lab, d in zip(r["labels"], r["d_moduli"]):
        by_label.setdefault(lab, float(d))
    return {"parameter": r["parameter"], "d_moduli": [float(v) for v in r["d_moduli"]],
            "d_multipliers": [[float(complex(z).real), float(complex(z).imag)] for z in r["d_multipliers"]],
            "d_modulus_by_mode": by_label}


def _sensitivity_table(result: dict, top: int) -> str:
    modes = [m for m in ("spiral", "dutch_roll_like", "roll_subsidence", "lateral_real", "longitudinal")
             if any(m in r["d_modulus_by_mode"] for r in result["sensitivities"])]
    lines = ["sensitivity of the 6-DOF multipliers (fixed amplitude), d|Lambda| per unit of the parameter "
             "(longitudinal: the first longitudinal multiplier in the list):",
             f"  {'parameter':40s}" + "".join(f" {m:>16s}" for m in modes)]
    rows = sorted(result["sensitivities"], key=lambda r: -max(abs(v) for v in r["d_modulus_by_mode"].values()))
    for r in rows[:top]:
        lines.append(f"  {r['parameter']:40s}" + "".join(f" {r['d_modulus_by_mode'].get(m, float('nan')):+16.3e}"
                                                         for m in modes))
    lines.append(f"  model validity of the cycle: {validity_text(result.get('validity'))}")
    return "\n".join(lines)
