"""Observed order of the bird's RK4 grid: the multipliers of ``trim`` (reference case) on a sequence of
steps per period, with the reference wing geometry (``wing.smooth_geometry = false``, the default) and
the switch-free one (``true``, docs/model.md §4.8). Errors are taken against the finest grid of the
same geometry; the observed order is log2(e_N / e_2N). Also the solver's own error estimate
(``error_estimate=True``: a re-solve on 2N steps) at the default grid (148 steps) against that error.
Numbers quoted in docs/model.md §4.8.

    python scripts/rk4_order.py [--out results/engine/rk4_order]

Writes rk4_order.json and rk4_order.png (log-log error against steps).
"""
from __future__ import annotations

import math
import time

import numpy as np

from script_common import parse_with_out, script_parser

STEPS = (12, 24, 48, 96, 192, 384, 768)
FINEST = 3072
DEFAULT_STEPS = 148


def multipliers(cfg, steps: int, compiled: bool, error_estimate: bool = False):
    """Multipliers sorted by modulus (largest first) and the trim result."""
    from birdocp import trim

    r = trim(cfg, steps_per_period=steps, compiled=compiled, error_estimate=error_estimate)
    if not r.success:
        raise SystemExit(f"trim did not converge at {steps} steps (smooth={cfg.wing.smooth_geometry})")
    mu = np.asarray(r.multipliers, complex)
    return mu[np.argsort(-np.abs(mu))], r


def geometry_rows(smooth: bool, compiled: bool) -> dict:
    """The convergence table of one geometry."""
    from birdocp import Config, with_values

    cfg = with_values(Config(), {"wing.smooth_geometry": smooth})
    t0 = time.perf_counter()
    ref, r_ref = multipliers(cfg, FINEST, compiled)
    rows = []
    for n in STEPS:
        mu, r = multipliers(cfg, n, compiled)
        rows.append({"steps_per_period": n, "multipliers_abs": np.abs(mu).tolist(),
                     "error": float(np.max(np.abs(mu - ref))), "valid": bool(r.validity.valid)})
    for a, b in zip(rows, rows[1:]):
        a["observed_order"] = math.log2(a["error"] / b["error"]) if b["error"] > 0 else None
    mu, r = multipliers(cfg, DEFAULT_STEPS, compiled, error_estimate=True)
    est = r.error_estimate or {}
    return {"smooth_geometry": smooth, "finest_steps": FINEST, "finest_multipliers_abs": np.abs(ref).tolist(),
            "finest_valid": bool(r_ref.validity.valid), "rows": rows,
            "default_grid": {"steps_per_period": DEFAULT_STEPS, "error_vs_finest": float(np.max(np.abs(mu - ref))),
                             "error_estimate_multipliers": est.get("multipliers")},
            "wall_time_s": time.perf_counter() - t0}


def figure(tables: list, path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.2))
    for tab, style in zip(tables, ("o-", "s-")):
        n = [r["steps_per_period"] for r in tab["rows"]]
        e = [r["error"] for r in tab["rows"]]
        label = "smooth geometry" if tab["smooth_geometry"] else "reference geometry (default)"
        ax.loglog(n, e, style, label=label)
    n = np.array(STEPS, float)
    e0 = tables[1]["rows"][1]["error"]
    ax.loglog(n, e0 * (n / n[1]) ** -4, "k:", label="slope -4")
    ax.set_xlabel("RK4 steps per period")
    ax.set_ylabel(f"max |multiplier error| vs {FINEST} steps")
    ax.set_title("Bird trim (reference case): RK4 grid convergence")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> None:
    from birdocp.io.files import atomic_write_json

    ap = script_parser(__doc__, "results/engine/rk4_order")
    args, out = parse_with_out(ap, argv)
    tables = [geometry_rows(flag, args.compiled) for flag in (False, True)]
    for tab in tables:
        print(f"smooth_geometry={tab['smooth_geometry']}:")
        for r in tab["rows"]:
            print(f"  N={r['steps_per_period']:5d}  error={r['error']:.3e}  order={r.get('observed_order')}")
        print(f"  default grid: {tab['default_grid']}")
    atomic_write_json(out / "rk4_order.json", {"tables": tables})
    figure(tables, out / "rk4_order.png")


if __name__ == "__main__":
    main()
