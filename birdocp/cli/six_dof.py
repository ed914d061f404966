"""The six-degree-of-freedom path of ``trim`` and ``level`` (``model.degrees_of_freedom = 6``): one
run folder with the 9-state cycle, every multiplier and the lateral modes (not a command itself)."""

from __future__ import annotations

import argparse
import time

from birdocp.cli.common import EXIT_OK, fmt_num, finish_result, format_trim_table, run_folder

def level_options(kw: dict) -> dict:
    """The 6-DOF level options from the planar level's checked keywords: the amplitude solved for a
    mean vertical speed (other free keys and conditions are refused, one line;
    :func:`birdocp.studies.lateral.level_keywords`)."""
    from birdocp.studies.lateral import level_keywords

    return level_keywords(kw)


def format_lateral_table(r: dict) -> str:
    """The lateral part of a 6-DOF result: the split, the heading multiplier and the labelled modes."""
    lines = ["", "six degrees of freedom: state (u, v, w, p, q, r, phi, theta, psi)",
             f"  heading multiplier {fmt_num(r.get('heading_multiplier'), '.12g')} (psi: reported apart, "
             "not a stability mode)",
             f"  longitudinal-lateral coupling in the monodromy: max {fmt_num(r.get('coupling_max'), '.2e')}",
             f"  lateral verdict: {_verdict(r.get('lateral_stable'))}",
             "  lateral modes (beats: wingbeats to double, negative: to halve)",
             f"    {'label':<17} {'re':>12} {'im':>12} {'modulus':>10} {'beats':>10}  dominant"]
    for m in r.get("lateral_modes") or []:
        re_, im = m["multiplier"] if isinstance(m["multiplier"], (list, tuple)) else (m["multiplier"], 0.0)
        mod = (re_ ** 2 + im ** 2) ** 0.5
        lines.append(f"    {m['label']:<17} {fmt_num(re_):>12} {fmt_num(im):>12} {fmt_num(mod, '.6f'):>10} "
                     f"{fmt_num(m.get('beats_to_double'), '.4g'):>10}  {m.get('dominant_state')}")
    return "\n".join(lines)


def _verdict(stable) -> str:
    return "stable" if stable is True else "unstable" if stable is False else "unknown"


def run_six_dof(args: argparse.Namespace, command: str, command_line: list[str], cfg, options: dict) -> int:
    """Solve ``cfg`` in six degrees of freedom (``options``: :func:`birdocp.studies.lateral.lateral_trim`
    keywords), write the run folder, print the table or the JSON; the exit code."""
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
        run.output(result, head + table + "\n" + format_lateral_table(result))
        if not res.success:
            return run.fail(f"{command} did not converge", c.status, c.max_residual, c.message)
    return EXIT_OK
