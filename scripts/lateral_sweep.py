"""Experiment 3 with the lateral multipliers: the stability-margin sweep (wing-root position, SM =
-root_ahead_m / c) of the six-degree-of-freedom bird, at the paper's amplitude (42 deg) and in level
flight, every row with its lateral (v, p, r, phi) and longitudinal (u, w, q, theta) multipliers and
its model validity.

Each family is two warm-started lines out from the reference root (5 cm, SM -25 %): towards the front
to 6.5 cm (level flight: to 5.7 cm; the planar level branch reaches the 70 deg amplitude bound at
5.76 cm) and towards the rear to 1 cm (SM -5 %), the range of scripts/experiment3.py. The solves use
the configuration's shooting method (as ``birdocp sweep``); ``run`` is timed by
scripts/benchmark_sixdof.py (target: under 2 minutes on the 2-core machine). The four lines
are independent jobs (``--jobs``, default 2 processes). Writes result.json (every row), sweep.csv,
table.md and margin.png (the moduli against SM; invalid points grey) to --out. The mode labels of the
figure and of the table's spiral column are carried from the reference root along each family by the
continuity of the eigenvectors (:func:`birdocp.studies.lateral_modes.track_modes`): where the
Dutch-roll-like pair splits into two real modes and one of them meets the roll subsidence (between
SM -15 % and -12.5 %), the modes keep their lineage instead of being renamed by the per-point rule.

    python scripts/lateral_sweep.py --out results/lateral/sweep
"""
from __future__ import annotations

import csv
import io
import json
import os
import time

import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.engine.executors import get_executor
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.studies.branch import sm_percent
from birdocp.studies.sweep import CSV_COLUMNS, SIX_DOF_COLUMNS, sweep
from script_common import parse_with_out, script_parser

CHORD_M = 0.2
FRONT_CM = (5.0, 5.25, 5.5, 5.75, 6.0, 6.25, 6.5)
LEVEL_FRONT_CM = (5.0, 5.1, 5.2, 5.3, 5.4, 5.5, 5.6, 5.7)
REAR_CM = (5.0, 4.75, 4.5, 4.25, 4.0, 3.5, 3.0, 2.5, 2.0, 1.5, 1.0)
"""Root positions [cm ahead of G] of the lines, in solving order: finer where the validity and the
level-flight amplitude change fast, 0.5 cm in the rear part (not valid in the planar Experiment 3)."""
LINES = {"fixed_up": (False, FRONT_CM), "fixed_down": (False, REAR_CM),
         "level_up": (True, LEVEL_FRONT_CM), "level_down": (True, REAR_CM)}
"""Each line: (level flight, root positions [cm])."""


def run_line(job: dict) -> dict:
    """One warm-started line of 6-DOF solves (a job of the executor)."""
    level, values = LINES[job["name"]]
    cfg = with_values(Config(), {"model.degrees_of_freedom": 6})
    t = time.perf_counter()
    rows = sweep(cfg, "wing.root_ahead_m", [round(v / 100, 6) for v in values], level=level, progress=False)
    return {"name": job["name"], "rows": rows, "wall_s": time.perf_counter() - t}


def run(jobs: int = 2) -> dict:
    """Solve the four lines (longest first) and merge them per family, ordered by root position."""
    t0, load = time.perf_counter(), os.getloadavg()[0]
    ex = get_executor(jobs if jobs > 1 else None)
    order = ["level_down", "fixed_down", "level_up", "fixed_up"]
    with ex:
        lines = {r["name"]: r for r in ex.map(run_line, [{"name": n} for n in order])}
    fams = {}
    for fam in ("fixed", "level"):
        up, down = lines[f"{fam}_up"]["rows"], lines[f"{fam}_down"]["rows"]
        rows = sorted(up[::-1] + down[1:], key=lambda r: -r["value"])
        for r in rows:
            r["root_ahead_cm"] = round(100 * r["value"], 6)
            r["sm_percent"] = sm_percent(r["value"], CHORD_M)
        fams[fam] = rows
    return {"families": fams, "line_wall_s": {k: v["wall_s"] for k, v in lines.items()},
            "wall_s": time.perf_counter() - t0, "jobs": jobs, "executor": ex.describe(), "load_average_start": load}


def csv_text(res: dict) -> str:
    cols = ["family", "root_ahead_cm", "sm_percent"] + CSV_COLUMNS + SIX_DOF_COLUMNS
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    for fam, rows in res["families"].items():
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in cols} | {"family": fam})
    return buf.getvalue()


def _f(v, fmt=".4f") -> str:
    return "-" if v is None else format(v, fmt)


def table(res: dict) -> str:
    lines = ["# Experiment 3 with the lateral multipliers (6 DOF)", "",
             "Stability margin SM = -root_ahead / c (c = 0.2 m). Moduli of the lateral (v, p, r, phi) and "
             "longitudinal (u, w, q, theta) multipliers; the heading's multiplier 1 is left out. "
             "`valid`: the model's validity on the cycle (docs/studies/validity.md). `spiral`: the mode "
             "followed by eigenvector continuity from the reference root (5 cm), not relabelled at each point.", ""]
    for fam, title in (("fixed", "A = 42 deg"), ("level", "level flight")):
        lines += [f"## {title}", "", "| root [cm] | SM [%] | ok | valid | A [deg] | lateral moduli | spiral | "
                  "longitudinal moduli | lateral stable |", "|---|---|---|---|---|---|---|---|---|"]
        rows = res["families"][fam]
        spiral = _mode_series(rows)["spiral"]
        for r, sp in zip(rows, spiral):
            lat = ", ".join(_f(r.get(f"lateral_modulus{k}")) for k in range(4))
            lon = ", ".join(_f(r.get(f"longitudinal_modulus{k}")) for k in range(4))
            lines.append(f"| {r['root_ahead_cm']:.2f} | {r['sm_percent']:.2f} | {'yes' if r['success'] else 'NO'} | "
                         f"{'yes' if r.get('valid') else 'no'} | {_f(r.get('amplitude_deg'), '.3f')} | {lat} | "
                         f"{_f(None if np.isnan(sp) else float(sp))} | {lon} | {r.get('lateral_stable')} |")
        lines.append("")
    lw = res["line_wall_s"]
    lines.append(f"Wall time {res['wall_s']:.1f} s with {res['jobs']} processes (lines: "
                 + ", ".join(f"{k} {v:.1f} s" for k, v in lw.items()) + f"; target 120 s; load average {res.get('load_average_start', float('nan')):.1f} at the start).")
    return "\n".join(lines) + "\n"


REFERENCE_ROOT_M = 0.05
"""The reference root (the paper's gait, SM -25 %): the point whose mode labels are carried along."""
COUPLED = "dutch_roll_like+roll_subsidence"


def tracked_modes(rows: list[dict]) -> list[list[dict]]:
    """The lateral modes of a family's rows with their labels carried by eigenvector continuity from the
    reference root (:func:`birdocp.studies.lateral_modes.track_modes`), not relabelled point by point."""
    from birdocp.studies.lateral_modes import track_modes

    start = min(range(len(rows)), key=lambda i: abs(rows[i]["value"] - REFERENCE_ROOT_M))
    return track_modes([r.get("lateral_modes") or [] for r in rows], start)


def _mode_series(rows: list[dict]) -> dict:
    """Per row: the largest modulus of each tracked mode label, the largest lateral and longitudinal ones."""
    names = ("spiral", "dutch_roll_like", "roll_subsidence", COUPLED)
    out = {k: [] for k in names + ("lateral_max", "longitudinal_max")}
    for r, modes in zip(rows, tracked_modes(rows)):
        for k in names:
            out[k].append(max([float(np.hypot(*m["multiplier"])) for m in modes if m["label"] == k], default=np.nan))
        out["lateral_max"].append(r.get("lateral_modulus0") or np.nan)
        out["longitudinal_max"].append(r.get("longitudinal_modulus0") or np.nan)
    return {k: np.array(v, float) for k, v in out.items()}


def figure(res: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True, height_ratios=(3, 2))
    styles = {"lateral_max": ("C3", "--", "lateral, largest"), "spiral": ("C0", "-", "spiral"),
              "dutch_roll_like": ("C1", "-", "Dutch-roll-like (pair; one real branch after it splits)"),
              "longitudinal_max": ("k", "-", "longitudinal, largest"),
              "roll_subsidence": ("C2", "-", "roll subsidence"),
              COUPLED: ("C4", "-", "roll subsidence + Dutch-roll branch (complex pair)")}
    for col, (fam, title) in enumerate((("fixed", "A = 42 deg"), ("level", "level flight"))):
        rows = [r for r in res["families"][fam] if r["success"]]
        sm = np.array([r["sm_percent"] for r in rows])
        valid = np.array([bool(r.get("valid")) for r in rows])
        series = _mode_series(rows)
        for k, (c, ls, lab) in styles.items():
            ax = axes[1 if k in ("roll_subsidence", COUPLED) else 0, col]
            y = series[k]
            ax.plot(sm, y, ls, color=c, lw=1.2, label=lab)
            ax.scatter(sm[valid], y[valid], color=c, s=14, zorder=3)
            ax.scatter(sm[~valid], y[~valid], color="0.75", s=24, zorder=4, edgecolor="0.35", lw=0.6)
        for ax in axes[:, col]:
            ax.axvspan(-32.5, -17.5, color="0.94", zorder=0)
        axes[0, col].axhline(1.0, color="0.3", lw=0.8, ls=":")
        axes[0, col].set_title(f"{title}")
        axes[1, col].set_yscale("log")
        axes[1, col].set_xlabel("stability margin SM [%] (wing root further ahead of G: left)")
    axes[0, 0].set_ylabel("|multiplier|")
    axes[1, 0].set_ylabel("|multiplier| (roll subsidence)")
    axes[0, 0].scatter([], [], color="0.75", edgecolor="0.35", s=24, label="model not valid")
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[1, 0].legend(loc="upper left", fontsize=8)
    fig.suptitle("6 DOF: Floquet multipliers over the stability margin, modes followed by eigenvector continuity "
                 "from SM -25 % (shaded: the paper's range;\ngrey points: model not valid there)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> dict:
    ap = script_parser(__doc__, "results/lateral/sweep")
    ap.add_argument("--jobs", type=int, default=2, help="local processes (default %(default)s)")
    ap.add_argument("--replot", action="store_true", help="redraw margin.png and table.md from --out's result.json")
    args, out = parse_with_out(ap, argv)
    if args.replot:
        res = json.loads((out / "result.json").read_text())
        atomic_write_text(out / "table.md", table(res))
        figure(res, out / "margin.png")
        return res
    res = run(args.jobs)
    atomic_write_json(out / "result.json", res)
    atomic_write_text(out / "sweep.csv", csv_text(res))
    atomic_write_text(out / "table.md", table(res))
    figure(res, out / "margin.png")
    print(f"lateral margin sweep: {res['wall_s']:.1f} s ({res['jobs']} processes); written to {out}")
    return res


if __name__ == "__main__":
    main()
