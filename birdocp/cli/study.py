"""CLI commands beyond the paper: ``sensitivity`` and ``optimize-stability`` (registered by cli.py)."""

from __future__ import annotations

import argparse
import sys
import time

from birdocp.bird.config import PARAM_NAMES, ConfigError, suggest
from birdocp.bird.validity import validity_text
from birdocp.cli import common as cli


def register(sub, common) -> None:
    """Add ``sensitivity`` and ``optimize-stability`` to the CLI's subparsers."""
    p = sub.add_parser("sensitivity", parents=[common], help="exact derivatives of the Floquet multipliers "
                       "with respect to gait and morphology parameters, ranked",
                       description="Trim the configured gait and rank the parameters by the exact "
                                   "derivative of the expanding multiplier's modulus (the change of the "
                                   "cycle included), per degree or per cm. --level holds level flight: "
                                   "the amplitude is first solved for level flight and re-solved along "
                                   "every parameter direction.")
    p.add_argument("--param", action="append", metavar="KEY",
                   help="parameter to differentiate (repeatable; default: every gait joint and the morphology)")
    p.add_argument("--level", action="store_true", help="hold level flight (amplitude re-solved)")
    p.add_argument("--top", type=int, default=15, metavar="N", help="rows to print (default 15)")
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty)")
    p.set_defaults(func=cmd_sensitivity)

    p = sub.add_parser("optimize-stability", parents=[common],
                       help="the gait within bounds that minimises the largest multiplier of level flight",
                       description="Minimise the largest Floquet multiplier modulus of a level-flight cycle "
                                   "over free gait parameters within bounds (Jury conditions on the "
                                   "monodromy's characteristic polynomial), then verify with numpy "
                                   "eigenvalues and a trim from scratch at the optimum.")
    p.add_argument("--free", action="append", metavar="KEY",
                   help="free parameter (repeatable; default: shoulder incidence and sweep offsets "
                        "and amplitudes)")
    p.add_argument("--bounds", action="append", metavar="KEY=LO:HI",
                   help="bounds of a free parameter (repeatable; default: birdocp.studies.optimize.DEFAULT_FREE)")
    p.add_argument("--climb-rate", type=float, default=0.0, metavar="MPS", help="mean vertical speed (default 0)")
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty)")
    p.set_defaults(func=cmd_optimize)


def _check_key(key: str, flag: str) -> str:
    if key not in PARAM_NAMES:
        raise ConfigError(flag, f"unknown parameter '{key}'" + suggest(key, PARAM_NAMES))
    return key


def cmd_sensitivity(args: argparse.Namespace, command_line: list[str]) -> int:
    from birdocp.io.runs import claim_out_dir, new_run_dir, write_run

    t0 = time.perf_counter()
    cfg = cli.resolve_config(args)
    params = [_check_key(k, "--param") for k in (args.param or [])] or None
    if args.top < 1:
        raise ConfigError("--top", f"must be >= 1, got {args.top}")
    run_dir = claim_out_dir(args.out, "sensitivity") if args.out else new_run_dir(None, "sensitivity")
    with cli.stdout_to_stderr():
        from birdocp.bird.config import with_values
        from birdocp.studies.sensitivity import multiplier_sensitivities
        from birdocp.studies.trim import trim

        if args.level:
            from birdocp.studies.level import level

            lv = level(cfg)
            base = trim(with_values(cfg, {"gait.shoulder_flap.amplitude_deg": lv.amplitude_deg}),
                        warm_start=lv) if lv.success else lv
        else:
            base = trim(cfg)
    if not base.success:
        print(f"{cli.PROG}: the cycle did not converge (status {base.status}): {base.message}", file=sys.stderr)
        write_run(run_dir, cfg, {"success": False, "status": base.status, "message": base.message},
                  None, command_line, command="sensitivity")
        return cli.EXIT_NOT_CONVERGED
    with cli.stdout_to_stderr():
        s = multiplier_sensitivities(base, params, hold_level=args.level)
    result = {"success": True, "amplitude_deg": base.amplitude_deg, **s.to_dict(), "validity": base.validity.to_dict(),
              "wall_s": {"total": time.perf_counter() - t0}, "run_dir": str(run_dir)}
    write_run(run_dir, base.cfg, result, None, command_line, command="sensitivity")
    if args.json:
        cli.print_json(result)
        return cli.EXIT_OK
    lam = s.multipliers[0]
    print(f"sensitivity of the expanding multiplier {lam.real:.6f} (|.| = {abs(lam):.6f}) at amplitude "
          f"{base.amplitude_deg:.4f} deg{' (level flight held)' if args.level else ''}; per unit of the parameter:")
    head = f"  {'parameter':42s} {'d|L1|':>11s} {'dL1 (re, im)':>24s} {'d mean W [m/s]':>15s}"
    if args.level:
        head += f" {'dA [deg]':>10s}"
    print(head)
    for row in s.ranked()[:args.top]:
        line = (f"  {row['parameter'] + ' /' + row['unit']:42s} {row['d_modulus_per_unit']:+11.3e} "
                f"{row['d_multiplier_per_unit'][0]:+11.3e} {row['d_multiplier_per_unit'][1]:+11.3e}j "
                f"{row['d_mean_vertical_speed_mps_per_unit']:+15.3e}")
        if args.level:
            line += f" {row['d_amplitude_deg_per_unit']:+10.3e}"
        print(line)
    print(f"  model validity of the cycle: {validity_text(result['validity'])}")
    print(f"  ({len(s.parameters)} parameters, {result['wall_s']['total']:.1f} s; written to {run_dir})")
    return cli.EXIT_OK


def cmd_optimize(args: argparse.Namespace, command_line: list[str]) -> int:
    import math

    from birdocp.studies.optimize import DEFAULT_FREE, optimize_stability
    from birdocp.io.runs import claim_out_dir, new_run_dir, write_run

    cfg = cli.resolve_config(args)
    if not math.isfinite(args.climb_rate):
        raise ConfigError("--climb-rate", f"must be finite, got {args.climb_rate}")
    keys = [_check_key(k, "--free") for k in (args.free or [])] or list(DEFAULT_FREE)
    bounds = {}
    for text in args.bounds or []:
        try:
            key, rng = text.split("=", 1)
            lo, hi = (float(v) for v in rng.split(":"))
        except ValueError:
            raise ConfigError("--bounds", f"expected KEY=LO:HI, got '{text}'") from None
        bounds[_check_key(key.strip(), "--bounds")] = (lo, hi)
    free = {}
    for k in keys:
        if k in bounds:
            free[k] = bounds[k]
        elif k in DEFAULT_FREE:
            free[k] = DEFAULT_FREE[k]
        else:
            raise ConfigError("--bounds", f"'{k}' has no default range; give --bounds {k}=LO:HI")
    for k in bounds:
        if k not in free:
            raise ConfigError("--bounds", f"'{k}' is not free; add --free {k}")
    run_dir = claim_out_dir(args.out, "optimize-stability") if args.out else new_run_dir(None, "optimize-stability")
    from birdocp.io.progress import progress_callback

    say, bar = progress_callback("optimize-stability", args.quiet)
    with cli.stdout_to_stderr(), bar:
        res = optimize_stability(cfg, free, climb_rate_mps=args.climb_rate, progress=say)
    result = res.to_dict()
    result["run_dir"] = str(run_dir)
    write_run(run_dir, res.cfg or cfg, result, None, command_line, command="optimize-stability")
    if args.json:
        cli.print_json(result)
    else:
        print(f"optimize-stability: {'converged' if res.success else 'NOT converged'} ({res.status}), "
              f"{res.iterations} iterations, {res.wall_s.get('total', 0):.1f} s")
        print(f"  largest multiplier modulus {max(abs(res.multipliers)):.6f} (start {max(abs(res.start_multipliers)):.6f}); "
              f"{'STABLE' if res.stable else 'UNSTABLE'} level flight at amplitude {res.amplitude_deg:.4f} deg")
        for k, v in res.free.items():
            lo, hi = res.bounds[k]
            at = " (at a bound)" if min(abs(v - lo), abs(v - hi)) < 1e-6 else ""
            print(f"  {k:40s} {v:+10.4f}   in [{lo:g}, {hi:g}]{at}")
        print("  multipliers: " + ", ".join(f"{z.real:.5f}{z.imag:+.5f}j" for z in res.multipliers))
        v = res.verification
        if v:
            print(f"  check: trim at the optimum {'converged' if v.get('trim_success') else 'FAILED'}, "
                  f"multipliers differ by {v.get('max_multiplier_difference')}, mean W {v.get('trim_mean_vertical_speed_mps')}")
        print(f"  model validity of the optimal cycle: {validity_text(result.get('validity'))}")
        print(f"  written to {run_dir}")
    if not res.success:
        print(f"{cli.PROG}: optimisation did not converge (status {res.status}); result written to {run_dir}",
              file=sys.stderr)
        return cli.EXIT_NOT_CONVERGED
    return cli.EXIT_OK
