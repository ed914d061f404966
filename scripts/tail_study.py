"""The paper's second open question: does a tail stabilise the flight, where the model holds?

The tail (spec 7, ``[tail]``) is opened by continuation in its opening angle beta, for several values
of its own incidence ``tail.incidence_deg`` (0: the delta in the body axis, the reference model):

* ``level_i<i>``: level flight held (the flapping amplitude solved, bounds 20..90 deg), beta from 0 to
  ``--max-deg``, one branch per incidence i (at beta = 0 the tail has no span: every branch starts
  from the paper's level cycle);
* ``fixed_42deg``: the paper's gait at amplitude 42 deg (no level flight held), incidence 0.

Every point carries the exact validity of its cycle (:func:`birdocp.bird.validity.periodic_validity`)
and the margins of the validity limits; where a limit is crossed a ``validity_boundary`` special point
is located on the branch, naming the limit. A point is a *flight* where the model is valid and
|mean W| < 1 m/s (else a dive, or invalid).

With ``--optimize``: the most stable level gait with the tail's incidence and opening angle free
together with the shoulder keys of ``optimize-stability`` (:data:`OPT_FREE`), every limit of
``[validity]`` a constraint (``optimize_stability(valid=True)``); its certificate (r*, KKT residual,
active limits and bounds, exact validity) goes to OUT/optimum_valid.json and the table.

Writes OUT/ (``--out``, default results/tail): branch_<family>.json, summary.json, table.md, tail.png.

    python scripts/tail_study.py                  # ~5-8 min on 2 cores
    python scripts/tail_study.py --reuse          # redraw from the branch files
    python scripts/tail_study.py --reuse --optimize   # + the valid stability optimum, tail keys free
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.studies.branch import add_validity, bird_branch
from birdocp.engine.continuation import Branch
from script_common import parse_with_out, script_parser

AMP = "gait.shoulder_flap.amplitude_deg"
INCIDENCES_DEG = (-15.0, -10.0, -5.0, 0.0, 5.0, 10.0, 15.0)
TAIL_FREE = {"tail.opening_angle_deg": (0.0, 60.0), "tail.incidence_deg": (-15.0, 15.0)}
"""The tail's keys freed with ``--optimize`` (bounds: the branches' ranges), starting at β = 0, i = 0."""
STYLE = {"flight": dict(ls="-", lw=2.0), "dive": dict(ls=":", lw=2.0), "invalid": dict(ls="--", lw=1.0, color="0.6")}


def family_name(level: bool, incidence_deg: float) -> str:
    return f"level_i{incidence_deg:+g}" if level else "fixed_42deg"


def run_family(level: bool, incidence_deg: float, max_deg: float) -> dict:
    """One branch in the opening angle at a fixed incidence (validity on every point, boundaries located)."""
    cfg = with_values(Config(), {"tail.enabled": True, "tail.incidence_deg": incidence_deg})
    t0 = time.perf_counter()
    br = bird_branch(cfg, "tail.opening_angle_deg", 0.0, max_deg, level=level, bounds=(20.0, 90.0) if level else None,
                     max_points=150 if level else 200)
    d = br.to_dict()
    d["script_wall_s"] = time.perf_counter() - t0
    d["tail_incidence_deg"] = incidence_deg
    return d


def point_class(p) -> str:
    """flight (valid, |mean W| < 1 m/s), dive (valid, mean W <= -1 m/s) or invalid."""
    if not p["validity"]["valid"]:
        return "invalid"
    return "flight" if abs(p["means"].get("vertical_speed_mps", 0.0)) < 1.0 else "dive"


def draw_classes(ax, x, y, classes, color, label):
    """One line per run of equal class (solid: flight, dotted: dive, grey dashed: model invalid)."""
    start, seen = 0, set()
    for i in range(1, len(x) + 1):
        if i == len(x) or classes[i] != classes[start]:
            c = classes[start]
            st = dict(STYLE[c])
            st.setdefault("color", color)
            j = min(i + 1, len(x))  # overlap one point so the runs join
            ax.plot(x[start:j], y[start:j], label=f"{label}: {c}" if c not in seen else None, **st)
            seen.add(c)
            start = i


def violated(p: dict) -> list:
    """The validity limits a point violates (their [validity] keys: negative margins)."""
    from birdocp.bird.validity import validity_margins

    return sorted(k for k, v in validity_margins(p["validity"]).items() if v < 0)


def summarise(d: dict) -> dict:
    """The family's numbers: ranges, classes, the best flight point, the validity boundaries, stable points."""
    pts = d["points"]
    beta = np.array([p["parameter"] for p in pts])
    m1 = np.array([p["moduli"][0] for p in pts])
    cls = [point_class(p) for p in pts]
    flight = [i for i, c in enumerate(cls) if c == "flight"]
    k = min(flight, key=lambda i: m1[i]) if flight else None
    stable = [i for i in range(len(pts)) if m1[i] < 1]
    return {
        "tail_incidence_deg": d.get("tail_incidence_deg", 0.0), "level": bool(d["settings"].get("level")),
        "beta_range_deg": [float(beta.min()), float(beta.max())], "end_reason": d["end_reason"],
        "end_message": d["end_message"], "points": len(pts), "flight_points": len(flight),
        "dive_points": cls.count("dive"), "invalid_points": cls.count("invalid"), "m1_at_0": float(m1[0]),
        "min_m1_in_flight": float(m1[k]) if k is not None else None,
        "beta_at_min_m1_in_flight": float(beta[k]) if k is not None else None,
        "best_flight_point": ({"beta_deg": float(beta[k]), "largest_modulus": float(m1[k]), "x0": pts[k]["x0"],
                               "free_values": pts[k]["free_values"], "means": pts[k]["means"],
                               "validity": pts[k]["validity"]} if k is not None else None),
        "stable_anywhere": bool(stable), "stable_in_flight": bool(k is not None and m1[k] < 1),
        "stable_points": [{"beta_deg": float(beta[i]), "largest_modulus": float(m1[i]), "valid": pts[i]["validity"]["valid"],
                           "limits_violated": violated(pts[i]), "reasons": pts[i]["validity"]["reasons"],
                           "class": cls[i], "x0": pts[i]["x0"], "free_values": pts[i]["free_values"],
                           "mean_vertical_speed_mps": pts[i]["means"].get("vertical_speed_mps")} for i in stable],
        "validity_boundaries": [{"beta_deg": s["parameter"], "limit": s["event"], "direction": s["direction"],
                                 "largest_modulus": max(s["moduli"]), "message": s["message"]}
                                for s in d.get("special_points", []) if s["kind"] == "validity_boundary"],
        "bifurcations": [{"kind": s["kind"], "beta_deg": s["parameter"]} for s in d.get("special_points", [])
                         if s["kind"] != "validity_boundary"],
    }


def figure(results: dict, out: Path) -> None:
    fig, axes = plt.subplots(1, 3, figsize=(19, 5.6))
    cmap = plt.get_cmap("viridis")  # no grey in it: grey is for points where the model does not hold
    inc = sorted({d.get("tail_incidence_deg", 0.0) for d in results.values()})
    span = max(1e-9, max(inc) - min(inc))
    for name, d in results.items():
        pts = d["points"]
        beta = np.array([p["parameter"] for p in pts])
        m1 = np.array([p["moduli"][0] for p in pts])
        cls = [point_class(p) for p in pts]
        i = d.get("tail_incidence_deg", 0.0)
        level = d["settings"].get("level")
        color = cmap(0.9 * (i - min(inc)) / span) if level else "k"
        label = f"i = {i:+g} deg" if level else "A = 42 deg, i = 0 (no level flight held)"
        draw_classes(axes[0], beta, m1, cls, color, label)
        for s in d.get("special_points", []):
            if s["kind"] == "validity_boundary":
                axes[0].plot(s["parameter"], max(s["moduli"]), "P", color=color, mec="k", ms=8, zorder=5)
        axes[0].plot(beta[-1], m1[-1], "|", ms=14, mew=2.5, color=color)
        if level:
            amp = np.array([p["free_values"][AMP] for p in pts])
            draw_classes(axes[1], beta, amp, cls, color, label)
            U = np.array([p["means"].get("forward_speed_mps", np.nan) for p in pts])
            draw_classes(axes[2], beta, U, cls, color, label)
    axes[0].plot([], [], "P", color="0.5", mec="k", label="validity boundary (located)")
    axes[0].axhline(1, color="k", lw=0.8)
    axes[0].set(xlabel="tail opening angle β [deg]", ylabel="largest multiplier modulus |Λ1|",
                title="expanding multiplier (|Λ1| < 1: stable)")
    axes[1].axhline(90.0, color="k", lw=0.8, ls="-.")
    axes[1].set(xlabel="tail opening angle β [deg]", ylabel="level-flight flapping amplitude [deg]",
                title="amplitude for level flight (bound 90 deg: branch end)")
    axes[2].set(xlabel="tail opening angle β [deg]", ylabel="mean forward speed U [m/s]",
                title="level-flight speed")
    handles, labels = axes[0].get_legend_handles_labels()
    uniq = dict(zip(labels, handles))
    fig.legend(uniq.values(), uniq.keys(), loc="lower center", ncol=5, fontsize=8, frameon=False,
               bbox_to_anchor=(0.5, -0.12))
    fig.suptitle("The tail with its own incidence i (continuation in the opening angle β). Solid: flight (model valid, "
                 "|mean W| < 1 m/s); dotted: dive; grey dashed: model NOT valid; | : branch end", fontsize=11)
    tmp = out / "tail.tmp.png"
    fig.savefig(tmp, dpi=110, bbox_inches="tight")
    plt.close(fig)
    tmp.replace(out / "tail.png")


def table(summary: dict, answer: list) -> str:
    lines = ["# The tail with its own incidence: continuation in its opening angle", "",
             "Flight = the model is valid on the cycle (birdocp.bird.validity, default thresholds) and |mean W| "
             "< 1 m/s. Validity boundaries are located on the branch (the limit crossed; ↓ leaving the model's "
             "validity, ↑ coming back).", "",
             "| family | incidence [deg] | β range [deg] | end | \\|Λ1\\| at β = 0 | min \\|Λ1\\| in flight (β) | "
             "points flight / dive / invalid | validity boundaries | stable anywhere (valid?) | stable in flight |",
             "|---|---:|---|---|---:|---|---|---|---|---|"]
    for name, s in summary["families"].items():
        vb = "; ".join(f"{'↓' if b['direction'] < 0 else '↑'} β = {b['beta_deg']:.3f}: {b['limit']}"
                       for b in s["validity_boundaries"]) or "none"
        st = s["stable_points"]
        stable = (f"yes, {len(st)} points ({sum(p['valid'] for p in st)} valid)" if st else "no")
        best = (f"{s['min_m1_in_flight']:.4f} ({s['beta_at_min_m1_in_flight']:.2f})"
                if s["min_m1_in_flight"] is not None else "-")
        lines.append(f"| {name} | {s['tail_incidence_deg']:+g} | {s['beta_range_deg'][0]:.2f} - "
                     f"{s['beta_range_deg'][1]:.2f} | {s['end_reason']} | {s['m1_at_0']:.4f} | {best} | "
                     f"{s['flight_points']} / {s['dive_points']} / {s['invalid_points']} | {vb} | {stable} | "
                     f"{'yes' if s['stable_in_flight'] else 'no'} |")
    opt = optimum_lines(summary["optimum_valid"]) if summary.get("optimum_valid") else []
    return "\n".join(lines + ["", "## Answer", ""] + [f"- {a}" for a in answer] + opt) + "\n"


def optimize_valid(threads: int = 2) -> dict:
    """The most stable valid level gait with the tail's incidence and opening free (see the module)."""
    from birdocp.studies.optimize import DEFAULT_FREE, optimize_stability

    # from the closed tail (beta = 0: the reference level cycle, which the default guess finds; at
    # beta = 10 deg the coarse stage's Newton did not find a level cycle from it)
    cfg = with_values(Config(), {"tail.enabled": True, "tail.opening_angle_deg": 0.0, "tail.incidence_deg": 0.0})
    t0 = time.perf_counter()
    opt = optimize_stability(cfg, dict(DEFAULT_FREE) | TAIL_FREE, valid=True, threads=threads)
    d = opt.to_dict()
    active = [k for k, c in (d.get("validity_constraints") or {}).items() if c.get("active")]
    return d | {"free_bounds": {k: list(v) for k, v in (dict(DEFAULT_FREE) | TAIL_FREE).items()},
                "active_validity_limits": active, "script_wall_s": time.perf_counter() - t0}


def at_bound(o: dict) -> list:
    """The free keys of the optimum ``o`` at a bound (:func:`birdocp.engine.oracle.active_bounds`, the
    rule of every optimum's ``active_bounds``), as 'key = bound'."""
    from birdocp.engine.oracle import active_bounds

    out = []
    for k in active_bounds(o["free"], o["bounds"]):
        v, (lo, hi) = o["free"][k], o["bounds"][k]
        out.append(f"{k} = {lo:g}" if v - lo < hi - v else f"{k} = {hi:g}")
    return out


def optimum_lines(o: dict) -> list:
    """The certificate of the valid stability optimum with the tail keys free, in words."""
    if o.get("radius") is None:
        return ["", "## The most stable valid gait with the tail's incidence and opening free", "",
                f"optimize_stability(valid=True) FAILED: {o['status']}: {o['message'][:300]}"]
    r = max(o["moduli"])
    verdict = ("stable" if o["stable"] else "NOT stable") + (" where the model holds" if o["validity"]["valid"]
                                                             else ", and the model does NOT hold there")
    fv = ", ".join(f"{k} {v:.3f}" for k, v in o["free"].items())
    return ["", "## The most stable valid gait with the tail's incidence and opening free", "",
            f"optimize_stability(valid=True), free: {', '.join(o['free_bounds'])} (bounds in optimum_valid.json).", "",
            f"- status {o['status']} ({'converged' if o['success'] else 'NOT converged'}), {o['iterations']} iterations, "
            f"{o['script_wall_s']:.0f} s",
            f"- r* = {o['radius']:.6f}, largest |Λ| = {r:.6f}: {verdict}",
            f"- KKT residual {o['kkt_residual']:.2e}, constraint violation {o['constraint_violation']:.1e}",
            f"- active validity limits: {', '.join(o['active_validity_limits']) or 'none'}; parameters at a bound "
            f"(within 1e-5 of the bound range: IPOPT's interior point stops that close): "
            f"{', '.join(at_bound(o)) or 'none'}; "
            f"flapping amplitude {o['amplitude_deg']:.5f} deg (its bounds 20-70 deg)",
            f"- exact validity: {'valid' if o['validity']['valid'] else 'NOT valid: ' + '; '.join(o['validity']['reasons'])}",
            f"- optimum: {fv}, amplitude {o['amplitude_deg']:.3f} deg"]


def answer_of(summary: dict) -> list:
    fams = summary["families"]
    flights = [(s["min_m1_in_flight"], n) for n, s in fams.items() if s["min_m1_in_flight"] is not None]
    best_m1, best = min(flights)
    b = fams[best]
    stable_valid = [(n, p) for n, s in fams.items() for p in s["stable_points"] if p["valid"]]
    stable_invalid = [(n, p) for n, s in fams.items() for p in s["stable_points"] if not p["valid"]]
    out = [f"Smallest |Λ1| of a valid level flight on any branch: {best_m1:.4f} ({best}, β = "
           f"{b['beta_at_min_m1_in_flight']:.2f} deg, amplitude "
           f"{b['best_flight_point']['free_values'].get(AMP, 42.0):.2f} deg, U = "
           f"{b['best_flight_point']['means'].get('forward_speed_mps', float('nan')):.2f} m/s)."]
    if stable_valid:
        n, p = stable_valid[0]
        out.append(f"Stable points where the model holds: {len(stable_valid)} (first: {n}, β = {p['beta_deg']:.2f}, "
                   f"|Λ1| {p['largest_modulus']:.4f}, {p['class']}).")
    else:
        out.append("No point with |Λ1| < 1 is valid: within these incidences and opening angles the tail does not "
                   "stabilise the flight where the model holds.")
    if stable_invalid:
        lim = sorted({k for _, p in stable_invalid for k in p["limits_violated"]})
        fams_ = sorted({n for n, _ in stable_invalid})
        th = max(abs(p["largest_modulus"]) for _, p in stable_invalid)
        out.append(f"{len(stable_invalid)} points with |Λ1| < 1 (up to {th:.4f}) lie where the model does NOT hold "
                   f"(on {', '.join(fams_)}; limits violated: {', '.join(lim)}); they are not flights.")
    return out


def main(argv=None):
    ap = script_parser(__doc__, "results/tail")
    ap.add_argument("--max-deg", type=float, default=60.0, help="largest opening angle (default 60)")
    ap.add_argument("--incidences", type=float, nargs="+", default=list(INCIDENCES_DEG), metavar="DEG",
                    help="tail incidences of the level-flight families (default %(default)s)")
    ap.add_argument("--reuse", action="store_true", help="redraw from the branch files in --out")
    ap.add_argument("--optimize", action="store_true",
                    help="also the most stable valid gait with the tail's incidence and opening free "
                         "(OUT/optimum_valid.json; without it an earlier one is kept in the table)")
    args, out = parse_with_out(ap, argv)
    results = {}
    for level, i in [(True, i) for i in args.incidences] + [(False, 0.0)]:
        name = family_name(level, i)
        path = out / f"branch_{name}.json"
        if args.reuse and path.exists():
            results[name] = json.loads(path.read_text())
            if any(p.get("validity") is None for p in results[name]["points"]):
                cfg = with_values(Config(), {"tail.enabled": True, "tail.incidence_deg": i})
                results[name] = add_validity(cfg, Branch.from_dict(results[name])).to_dict()
        else:
            results[name] = run_family(level, i, args.max_deg)
            print(f"{name}: {len(results[name]['points'])} points, {results[name]['end_reason']}, "
                  f"{results[name]['script_wall_s']:.0f} s", flush=True)
        atomic_write_json(path, results[name])
    summary = {"families": {n: summarise(d) for n, d in results.items()}}
    summary["answer"] = answer_of(summary)
    if args.optimize:
        atomic_write_json(out / "optimum_valid.json", optimize_valid())
    if (out / "optimum_valid.json").is_file():  # its active bounds judged by today's rule
        from birdocp.engine.oracle import active_bounds

        o = json.loads((out / "optimum_valid.json").read_text())
        if o.get("free") and o.get("bounds"):
            o["active_bounds"] = active_bounds(o["free"], o["bounds"])
            atomic_write_json(out / "optimum_valid.json", o)
        summary["optimum_valid"] = o
    atomic_write_json(out / "summary.json", summary)
    atomic_write_text(out / "table.md", table(summary, summary["answer"]))
    figure(results, out)
    print(table(summary, summary["answer"]))


if __name__ == "__main__":
    main()
