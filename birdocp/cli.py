"""Command-line interface: ``birdocp forces | trim | config``.

Configuration resolution (one helper, :func:`resolve_config`, used by every subcommand)::

    defaults  <-  CONFIG file  <-  --set KEY=VALUE ...  <-  dedicated flags (--amplitude, --points, ...)

The ``--set`` assignments and the dedicated flags are applied together in one step, so they may be
given in any order and e.g. ``--set solve.points=4 --steps 150`` is checked as a whole. The
configuration is fully validated before the model is imported or built.

Exit codes: 0 success; 1 the solver did not converge (the result is still written) or an unexpected
error; 2 bad input (one line on stderr naming the key at fault); 130 interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import time
import traceback
from pathlib import Path
from typing import Any, Iterator, Sequence

from . import config as C
from .config import ConfigError

__all__ = ["main", "build_parser", "resolve_config", "EXIT_OK", "EXIT_NOT_CONVERGED", "EXIT_BAD_INPUT"]

PROG = "birdocp"
EXIT_OK = 0
EXIT_NOT_CONVERGED = 1
EXIT_INTERNAL = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130

AMPLITUDE_KEY = "gait.shoulder_flap.amplitude_deg"
ROOT_AHEAD_KEY = "wing.root_ahead_m"


# ---------------------------------------------------------------------------------------------
# Parser

class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (still exit code 2)."""

    def error(self, message: str):  # noqa: D401 - argparse API
        hint = f"see '{self.prog} --help'"
        self.exit(EXIT_BAD_INPUT, f"{PROG}: error: {_one_line(message)}; {hint}\n")


def _common_options() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(add_help=False)
    g = p.add_argument_group("configuration (defaults <- CONFIG <- --set <- dedicated flags)")
    g.add_argument("config", nargs="?", metavar="CONFIG",
                   help="TOML configuration file (start one with 'birdocp config > bird.toml')")
    g.add_argument("--amplitude", type=float, metavar="DEG",
                   help=f"flapping amplitude in degrees (sets {AMPLITUDE_KEY})")
    g.add_argument("--root-ahead", type=float, metavar="M",
                   help=f"distance of the wing root ahead of the centre of mass in metres (sets {ROOT_AHEAD_KEY})")
    g.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="sets",
                   help="set a dotted config key, e.g. --set aero.circulation=relaxed (repeatable; "
                        "the value is read as TOML, bare words are strings)")
    o = p.add_argument_group("output")
    o.add_argument("--json", action="store_true", help="print one JSON object on stdout instead of a table")
    o.add_argument("--debug", action="store_true", help="show Python tracebacks on errors")
    return p


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = _Parser(
        prog=PROG,
        description="Trimmed periodic flapping flight of a bird and its Floquet stability.",
        epilog="Exit codes: 0 ok, 1 solver did not converge or internal error, 2 bad input, 130 interrupted. "
               "Run 'birdocp COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True, parser_class=_Parser)
    common = _common_options()

    p = sub.add_parser("forces", parents=[common], help="body-frame loads and state derivative at one state and time",
                       description="Evaluate the model once: body-frame loads (x' forward, z' down, "
                                   "pitching moment nose-up positive) and the state derivative.")
    p.add_argument("--state", nargs=4, type=float, required=True, metavar=("U", "W", "Q", "THETA"),
                   help="body-frame velocities u, w [m/s], pitch rate q [rad/s], pitch angle theta [rad]")
    p.add_argument("--time", type=float, required=True, metavar="T", help="time in the flapping cycle [s]")
    p.set_defaults(func=cmd_forces)

    p = sub.add_parser("trim", parents=[common], help="find the trimmed periodic flight and its Floquet stability",
                       description="Find the periodic (trimmed) flapping flight by multiple shooting and its "
                                   "Floquet multipliers. Writes a run folder (config.toml, result.json, arrays.npz).")
    s = p.add_argument_group("solve (shortcuts for solve.* keys)")
    s.add_argument("--points", type=int, metavar="M", help="shooting points per period, closing point included (solve.points)")
    s.add_argument("--steps", type=int, metavar="N", help="RK4 steps per period, a multiple of M-1 (solve.steps_per_period)")
    s.add_argument("--solver", choices=("ipopt", "lm"), help="nonlinear solver (solve.solver)")
    s.add_argument("--derivatives", choices=("exact", "fd"), help="Jacobians by AD or finite differences (solve.derivatives)")
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty); default runs/<time>-trim-<id>/")
    p.set_defaults(func=cmd_trim)

    p = sub.add_parser("config", parents=[common], help="print the resolved configuration as TOML",
                       description="Print the resolved configuration (defaults <- CONFIG <- --set <- flags) as "
                                   "TOML, e.g. to start a configuration file: birdocp config > bird.toml")
    p.set_defaults(func=cmd_config)
    return parser


# ---------------------------------------------------------------------------------------------
# Configuration

def _one_line(text: Any) -> str:
    return " ".join(str(text).split())


def _message(exc: ConfigError) -> str:
    """The message of a ConfigError without its ``key: `` prefix."""
    text = str(exc)
    prefix = f"{exc.key}: "
    return text[len(prefix):] if exc.key and text.startswith(prefix) else text


def _load_file(path_text: str) -> C.Config:
    path = Path(path_text)
    if not path.exists():
        raise ConfigError("CONFIG", f"file '{path}' does not exist; give the path of a TOML file "
                                    "(write one with 'birdocp config > bird.toml')")
    if path.is_dir():
        raise ConfigError("CONFIG", f"'{path}' is a folder; give the path of a TOML file")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ConfigError(str(path), "is not UTF-8 text; give a TOML file") from None
    except OSError as exc:
        raise ConfigError(str(path), f"cannot be read: {exc.strerror or exc}") from None
    try:
        return C.loads(text)
    except ConfigError as exc:
        if not exc.key:  # not valid TOML
            raise ConfigError(str(path), _message(exc)) from None
        raise ConfigError(exc.key, f"{_message(exc)} (in {path})") from None


def _parse_assignment(assignment: str) -> tuple[str, Any]:
    """``KEY=VALUE`` of ``--set``, the value parsed as by :func:`birdocp.config.set_value`."""
    if "=" not in assignment:
        raise ConfigError("--set", f"'{assignment}' is not KEY=VALUE; e.g. --set aero.circulation=relaxed")
    key, text = assignment.split("=", 1)
    key = key.strip()
    if not key:
        raise ConfigError("--set", f"missing key in '{assignment}'; expected KEY=VALUE, e.g. body.mass_kg=1.3")
    return key, C._parse_scalar(text.strip())


def _flag_values(args: argparse.Namespace) -> list[tuple[str, str, Any]]:
    """(flag, dotted key, value) of the dedicated flags that were given."""
    table = [
        ("--amplitude", AMPLITUDE_KEY, "amplitude"),
        ("--root-ahead", ROOT_AHEAD_KEY, "root_ahead"),
        ("--points", "solve.points", "points"),
        ("--steps", "solve.steps_per_period", "steps"),
        ("--solver", "solve.solver", "solver"),
        ("--derivatives", "solve.derivatives", "derivatives"),
    ]
    return [(flag, key, getattr(args, attr)) for flag, key, attr in table
            if getattr(args, attr, None) is not None]


def resolve_config(args: argparse.Namespace) -> C.Config:
    """The validated configuration: defaults <- CONFIG file <- --set <- dedicated flags."""
    cfg = _load_file(args.config) if getattr(args, "config", None) else C.Config()
    values: dict[str, Any] = {}
    for assignment in getattr(args, "sets", None) or []:
        key, value = _parse_assignment(assignment)
        values[key] = value
    flags = _flag_values(args)
    by_key = {}
    for flag, key, value in flags:
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(key, f"must be finite, got {value!r} (from {flag})")
        values[key] = value
        by_key[key] = flag
    if not values:
        return cfg
    try:
        return C.with_values(cfg, values)
    except ConfigError as exc:
        if exc.key in by_key:
            raise ConfigError(exc.key, f"{_message(exc)} (from {by_key[exc.key]})") from None
        raise


def _finite(name: str, values: Sequence[float]) -> list[float]:
    for v in values:
        if not math.isfinite(v):
            raise ConfigError(name, f"must be finite numbers, got {v!r}")
    return [float(v) for v in values]


# ---------------------------------------------------------------------------------------------
# Output helpers

@contextlib.contextmanager
def _stdout_to_stderr() -> Iterator[None]:
    """Send everything written to stdout (Python and C level, e.g. IPOPT) to stderr meanwhile."""
    sys.stdout.flush()
    saved = None
    try:
        saved = os.dup(1)
        os.dup2(2, 1)
    except OSError:
        saved = None
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        with contextlib.suppress(Exception):
            sys.stdout.flush()
            sys.stderr.flush()
        if saved is not None:
            os.dup2(saved, 1)
            os.close(saved)


def _num(x: Any, fmt: str = ".6g") -> str:
    if x is None:
        return "-"
    if isinstance(x, (list, tuple)) and len(x) == 2:
        re_, im = x
        return f"{_num(re_, fmt)} {'-' if (im or 0) < 0 else '+'} {_num(abs(im or 0), fmt)}j"
    try:
        return format(float(x), fmt)
    except (TypeError, ValueError):
        return str(x)


def _real(x: Any) -> float | None:
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


def _pairs(values: Any) -> list:
    return list(values) if isinstance(values, (list, tuple)) else []


def _growth(exponent: Any, doubling: Any) -> str:
    """'doubles in 0.3 s' / 'halves in 1.2 s' / 'neutral'."""
    rate = _real(exponent)
    t = _real(doubling)
    if t is not None and math.isfinite(t) and t != 0:
        sign = 1 if (rate is None and t > 0) or (rate is not None and rate > 0) else -1
        return f"{'doubles' if sign > 0 else 'halves'} in {abs(t):.4g} s"
    if rate is not None and rate != 0 and math.isfinite(rate):
        return f"{'doubles' if rate > 0 else 'halves'} in {math.log(2) / abs(rate):.4g} s"
    return "neutral"


def format_trim_table(r: dict) -> str:
    lines = []
    ok = bool(r.get("success"))
    lines.append(f"trim: {'converged' if ok else 'NOT converged'} (status: {r.get('status')})")
    if r.get("message"):
        lines.append(f"  {_one_line(r['message'])}")
    mults = _pairs(r.get("multipliers"))
    if mults:
        moduli = _pairs(r.get("moduli"))
        exps = _pairs(r.get("floquet_exponents", r.get("floquet_exponents_per_s")))
        dts = _pairs(r.get("doubling_times_s"))
        lines.append("")
        lines.append("Floquet multipliers (largest modulus first)")
        header = f"  {'#':>2}  {'re':>12}  {'im':>12}  {'modulus':>10}  {'exponent [1/s]':>24}  growth"
        lines.append(header)
        for i, m in enumerate(mults):
            re_, im = (m[0], m[1]) if isinstance(m, (list, tuple)) and len(m) == 2 else (m, 0.0)
            mod = moduli[i] if i < len(moduli) else (math.hypot(re_ or 0, im or 0) if re_ is not None else None)
            ex = exps[i] if i < len(exps) else None
            dt = dts[i] if i < len(dts) else None
            lines.append(f"  {i:>2}  {_num(re_):>12}  {_num(im):>12}  {_num(mod, '.6f'):>10}  "
                         f"{_num(ex):>24}  {_growth(ex, dt)}")
    lines.append("")
    stable = r.get("stable")
    verdict = "stable" if stable is True else "unstable" if stable is False else "unknown"
    rows = [
        ("verdict", verdict),
        ("mean forward speed", f"{_num(r.get('mean_forward_speed_mps'), '.4f')} m/s"),
        ("mean vertical speed", f"{_num(r.get('mean_vertical_speed_mps'), '.4f')} m/s"),
        ("flight path angle", f"{_num(r.get('flight_path_angle_deg'), '.4f')} deg"),
    ]
    x0 = r.get("x0")
    if isinstance(x0, (list, tuple)) and len(x0) == 4:
        u, w, q, th = x0
        rows.append(("x0 (u, w, q, theta)", f"{_num(u, '.6g')} m/s, {_num(w, '.6g')} m/s, "
                                              f"{_num(q, '.6g')} rad/s, {_num(th, '.6g')} rad"))
    rows.append(("iterations", str(r.get("iterations", "-"))))
    rows.append(("max residual", _num(r.get("max_residual"), ".3e")))
    sp = r.get("shooting_points")
    if isinstance(sp, int) or (isinstance(sp, (list, tuple)) and sp):
        rows.append(("shooting points", str(sp if isinstance(sp, int) else len(sp))))
    wall = r.get("wall_s")
    if isinstance(wall, dict):
        total = wall.get("total")
        phases = ", ".join(f"{k} {_num(v, '.3g')}" for k, v in wall.items() if k != "total")
        rows.append(("wall time", f"{_num(total, '.3g')} s" + (f" ({phases})" if phases else "")))
    elif wall is not None:
        rows.append(("wall time", f"{_num(wall, '.3g')} s"))
    if r.get("run_dir"):
        rows.append(("run folder", str(r["run_dir"])))
    width = max(len(k) for k, _ in rows)
    lines += [f"{k:<{width}}  {v}" for k, v in rows]
    return "\n".join(lines)


def _print_json(obj: Any) -> None:
    from .io import to_jsonable

    sys.stdout.write(json.dumps(to_jsonable(obj)) + "\n")
    sys.stdout.flush()


# ---------------------------------------------------------------------------------------------
# Commands

def cmd_config(args: argparse.Namespace, command_line: list[str]) -> int:
    cfg = resolve_config(args)
    if args.json:
        _print_json(C.to_dict(cfg))
    else:
        sys.stdout.write("# birdocp configuration (resolved)\n" + C.dumps(cfg))
    return EXIT_OK


def cmd_forces(args: argparse.Namespace, command_line: list[str]) -> int:
    state = _finite("--state", args.state)
    (t,) = _finite("--time", [args.time])
    cfg = resolve_config(args)

    import numpy as np

    from birdocp.model import get_model

    with _stdout_to_stderr():
        model = get_model(cfg)
        out = model.evaluate(state, t)
    res = {
        "Fx_N": float(np.asarray(out["Fx_N"], dtype=float).reshape(-1)[0]),
        "Fz_N": float(np.asarray(out["Fz_N"], dtype=float).reshape(-1)[0]),
        "My_Nm": float(np.asarray(out["My_Nm"], dtype=float).reshape(-1)[0]),
        "xdot": [float(v) for v in np.asarray(out["xdot"], dtype=float).reshape(-1)],
    }
    if args.json:
        _print_json(res)
        return EXIT_OK
    u, w, q, th = state
    xd = res["xdot"] + [float("nan")] * (4 - len(res["xdot"]))
    rows = [
        ("state", f"u = {u:g} m/s, w = {w:g} m/s, q = {q:g} rad/s, theta = {th:g} rad"),
        ("time", f"t = {t:g} s"),
        ("", ""),
        ("body-frame loads", "(x' forward, z' down, pitching moment nose-up positive)"),
        ("  Fx", f"{res['Fx_N']: .6g} N"),
        ("  Fz", f"{res['Fz_N']: .6g} N"),
        ("  My", f"{res['My_Nm']: .6g} N m"),
        ("state derivative", ""),
        ("  du/dt", f"{xd[0]: .6g} m/s^2"),
        ("  dw/dt", f"{xd[1]: .6g} m/s^2"),
        ("  dq/dt", f"{xd[2]: .6g} rad/s^2"),
        ("  dtheta/dt", f"{xd[3]: .6g} rad/s"),
    ]
    width = max(len(k) for k, _ in rows)
    print("\n".join(f"{k:<{width}}  {v}".rstrip() for k, v in rows))
    return EXIT_OK


def cmd_trim(args: argparse.Namespace, command_line: list[str]) -> int:
    from .runs import claim_out_dir, new_run_dir, write_run

    t_start = time.perf_counter()
    cfg = resolve_config(args)
    run_dir = claim_out_dir(args.out, "trim") if args.out else new_run_dir(None, "trim")
    try:
        with _stdout_to_stderr():
            from birdocp.studies import trim

            res = trim(cfg)
            result = dict(res.to_dict())
            arrays = res.arrays() if hasattr(res, "arrays") else None
    except BaseException:
        # nothing was written: do not leave an empty run folder behind
        with contextlib.suppress(OSError):
            run_dir.rmdir()
        raise
    wall = result.get("wall_s")
    wall = dict(wall) if isinstance(wall, dict) else ({} if wall is None else {"trim": wall})
    if "total" in wall:
        wall["trim"] = wall.pop("total")
    wall["total"] = time.perf_counter() - t_start
    result["wall_s"] = wall
    result["run_dir"] = str(run_dir)
    write_run(run_dir, cfg, result, arrays, command_line, command="trim")

    if args.json:
        _print_json(result)
    else:
        print(format_trim_table(result))
    if not res.success:
        hist = result.get("residual_history") or []
        last = result.get("max_residual")
        if last is None and hist:
            last = hist[-1]
        print(f"{PROG}: trim did not converge (status: {_one_line(res.status)}, last residual: {_num(last, '.3e')}): "
              f"{_one_line(res.message)}; result written to {run_dir}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


# ---------------------------------------------------------------------------------------------
# Entry point

def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (the console script passes it to ``sys.exit``)."""
    if argv is None:
        argv = sys.argv[1:]
        command_line = [PROG, *argv]
    else:
        argv = list(argv)
        command_line = [PROG, *argv]
    debug = "--debug" in argv
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help, --version, or a usage error (already printed)
            return exc.code if isinstance(exc.code, int) else EXIT_BAD_INPUT
        debug = args.debug
        return args.func(args, command_line)
    except KeyboardInterrupt:
        if debug:
            traceback.print_exc()
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except ConfigError as exc:
        if debug:
            traceback.print_exc()
        msg = _one_line(_message(exc))
        print(f"{PROG}: error: {exc.key}: {msg}" if exc.key else f"{PROG}: error: {msg}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:  # e.g. birdocp config | head -1
        with contextlib.suppress(OSError):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        return EXIT_OK
    except Exception as exc:
        if debug:
            traceback.print_exc()
        print(f"{PROG}: internal error: {type(exc).__name__}: {_one_line(exc)}"
              + ("" if debug else "; rerun with --debug for the traceback"), file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
