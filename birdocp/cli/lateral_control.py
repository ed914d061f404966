"""The six-degree-of-freedom path of ``birdocp control`` (``model.degrees_of_freedom = 6``): per-side
gait corrections, the periodic LQR on the exact 8-state wingbeat map (heading excluded)."""

from __future__ import annotations

import argparse
import sys
import time

from birdocp.cli import common as cli


def cmd_lateral_control(args: argparse.Namespace, command_line: list[str], cfg, t0: float) -> int:
    """``birdocp control`` with a 6-DOF configuration: one run folder (result.json with the gains
    (N, m, 8), multipliers.png); the exit code."""
    import numpy as np

    from birdocp.bird.config import dumps
    from birdocp.cli.control import check_options, failure_body, print_table
    from birdocp.studies.lateral_control import LATERAL_CONTROLS, resolve_lateral_controls

    controls = resolve_lateral_controls(args.controls if args.controls is not None else LATERAL_CONTROLS)
    N, limit = check_options(args, cfg)
    with cli.run_folder(args, "control", command_line) as run:
        with run.solving():
            from birdocp.studies.lateral_control import design_lateral_controller, lateral_reference_cycle

            base, cycle_cfg = lateral_reference_cycle(cfg, args.level)
        head = {"requested_config": dumps(cfg), "level": bool(args.level), "controls": controls,
                "updates_per_beat": N, "run_dir": str(run.dir), "degrees_of_freedom": 6}
        if not base.success:
            c = base.cycle
            result = {"success": False, "status": c.status, "message": c.message, **head}
            run.write(cfg, result)
            run.output(result, None)
            return run.fail("the cycle did not converge", c.status, c.max_residual, c.message)
        with run.solving():
            try:
                ctl = design_lateral_controller(base, cycle_cfg, controls, N, limit_deg=limit)
                body, message = ctl.to_dict(), ""
            except (np.linalg.LinAlgError, ValueError) as exc:
                ctl, (body, message) = None, failure_body(exc, controls)
        result = {**head, **body, "message": message or body["message"], "amplitude_deg": base.amplitude_deg,
                  "mean_forward_speed_mps": base.mean_forward_speed_mps,
                  "mean_vertical_speed_mps": base.mean_vertical_speed_mps, "cycle_symmetric": base.symmetric,
                  "cycle_multipliers": base.to_dict()["multipliers"], "wall_s": {"total": time.perf_counter() - t0}}
        if ctl is not None:
            from birdocp.plots.control import plot_multipliers

            result["figure"] = str(plot_multipliers(result, run.dir / "multipliers.png"))
        run.write(cycle_cfg, result)
        if args.json:
            run.output(result, None)
        else:
            print_table(result)
        if not result["success"]:
            print(f"{cli.PROG}: {result['message']}; result written to {run.dir}", file=sys.stderr)
            return cli.EXIT_NOT_CONVERGED
    return cli.EXIT_OK
