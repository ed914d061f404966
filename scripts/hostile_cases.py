"""Hostile cases through the real CLI: how each one ends (exit code, stderr line, JSON status).

Run:  python scripts/hostile_cases.py   (a few minutes; writes results/reliability/hostile_cases.{json,md})

Each case runs ``python -m birdocp ...`` (or the CLI with a SIGINT sent from inside a chosen
function, see HOOK) in a fresh temporary folder; the table records what a user would see.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from birdocp.io.files import atomic_write_json, atomic_write_text

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "results" / "reliability"
COARSE = ["--points", "3", "--steps", "60"]
# Runs the CLI after wrapping TARGET ("module:attr" or "module:Class.method") so that its N-th call
# sends SIGINT to this very process first (also used by tests/test_cli_faults.py).
HOOK = (
    "import importlib, os, signal, sys, runpy\n"
    "target, n = sys.argv[1], int(sys.argv[2])\n"
    "del sys.argv[1:3]\n"
    "mod_name, attr = target.split(':')\n"
    "owner = importlib.import_module(mod_name)\n"
    "*path, name = attr.split('.')\n"
    "for part in path:\n"
    "    owner = getattr(owner, part)\n"
    "orig = getattr(owner, name)\n"
    "calls = [0]\n"
    "def wrapped(*a, **k):\n"
    "    calls[0] += 1\n"
    "    if calls[0] == n:\n"
    "        os.kill(os.getpid(), signal.SIGINT)\n"
    "    return orig(*a, **k)\n"
    "setattr(owner, name, wrapped)\n"
    "sys.argv[0] = 'birdocp'\n"
    "runpy.run_module('birdocp', run_name='__main__', alter_sys=True)\n"
)
ENV = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))


def run(argv, cwd, hook=None, preexec=None, stdout=None, env=None):
    """``stdout``: None (captured), "closed" (``>&-``) or "broken pipe" (a reader that exited)."""
    cmd = [sys.executable, "-c", HOOK, *hook] if hook else [sys.executable, "-m", "birdocp"]
    t = time.perf_counter()
    kw = dict(cwd=cwd, env=dict(ENV, **(env or {})), text=True, timeout=600, preexec_fn=preexec)
    if stdout is None:
        p = subprocess.run([*cmd, *argv], capture_output=True, **kw)
    elif stdout == "closed":
        kw["preexec_fn"] = lambda: os.close(1)
        p = subprocess.run([*cmd, *argv], stdout=None, stderr=subprocess.PIPE, **kw)
        p.stdout = ""
    else:
        r, w = os.pipe()
        os.close(r)
        p = subprocess.run([*cmd, *argv], stdout=w, stderr=subprocess.PIPE, **kw)
        os.close(w)
        p.stdout = ""
    return p, time.perf_counter() - t


def size_limit(limit_bytes: int):
    """preexec_fn: a file-size limit (what a full disk does to a write: EFBIG, SIGXFSZ ignored)."""
    import resource

    def preexec():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
    return preexec


EXPORT_FILES = ("bird.h", "bird.c", "bird_data.c", "bird_casadi.c", "bird_casadi.h", "main.c", "Makefile")


def earlier_export(d: Path) -> None:
    (d / "e").mkdir()
    for name in EXPORT_FILES:
        (d / "e" / name).write_text(f"/* {name} of an earlier export */\n")


def export_intact(d: Path) -> str:
    same = all((d / "e" / n).read_text() == f"/* {n} of an earlier export */\n" for n in EXPORT_FILES)
    left = [p.name for p in d.iterdir() if p.name.startswith(".")]
    return f"earlier export {'intact' if same else 'CHANGED'}; temporary names left: {len(left)}"


def summary(case, p, wall, note=""):
    lines = p.stderr.strip().splitlines()
    status = None
    if p.stdout.strip().startswith("{"):  # --json runs
        try:
            status = json.loads(p.stdout.strip().splitlines()[-1]).get("status")
        except (ValueError, AttributeError):
            status = "(not JSON)"
    return {"case": case, "exit": p.returncode, "stderr_lines": len(lines), "last_line": lines[-1] if lines else "",
            "json_status": status, "wall_s": round(wall, 1), "note": note}


def main() -> None:
    rows = []
    root = Path(tempfile.mkdtemp(prefix="birdocp-hostile-"))

    def case(name, argv, hook=None, setup=None, note="", **how):
        d = root / f"c{len(rows):02d}"
        d.mkdir()
        if setup:
            setup(d)
        p, wall = run(argv, d, hook, **how)
        rows.append(summary(name, p, wall, note))
        print(f"{rows[-1]['exit']:>4}  {name}: {rows[-1]['last_line'][:110]}", flush=True)
        return d, p

    # output locations
    case("--out is a dangling symlink", ["trim", "--out", "link"], setup=lambda d: os.symlink(d / "gone", d / "link"))
    case("--out name longer than NAME_MAX", ["trim", "--out", "n" * 300])
    case("--out through a file", ["trim", "--out", "f/run"], setup=lambda d: (d / "f").write_text("x"))
    case("--out is a file", ["trim", "--out", "f"], setup=lambda d: (d / "f").write_text("x"))
    case("--out is a non-empty folder", ["trim", "--out", "full"],
         setup=lambda d: ((d / "full").mkdir(), (d / "full" / "x").write_text("x")))
    case("--out under /proc (kernel refuses)", ["trim", "--out", "/proc/birdocp-run"])
    ro_note = "root ignores permission bits: the run proceeds" if os.geteuid() == 0 else ""
    case("--out inside a chmod 555 folder", ["trim", *COARSE, "--out", "ro/run"],
         setup=lambda d: ((d / "ro").mkdir(), os.chmod(d / "ro", 0o555)), note=ro_note)
    case("runs/ is chmod 555", ["trim", *COARSE], setup=lambda d: ((d / "runs").mkdir(), os.chmod(d / "runs", 0o555)),
         note=ro_note)
    case("sweep --resume into a folder without sweep.json",
         ["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "1", "--out", "full", "--resume"],
         setup=lambda d: ((d / "full").mkdir(), (d / "full" / "x").write_text("x")))
    case("export-c --out dangling symlink", ["export-c", "--out", "link"],
         setup=lambda d: os.symlink(d / "gone", d / "link"))

    # absurd values
    case("sweep step larger than the range", ["sweep", "amplitude", "--from", "40", "--to", "42", "--by", "5"])
    case("sweep with 1e8 values", ["sweep", "amplitude", "--from", "0", "--to", "100", "--by", "1e-6"])
    case("--steps 1000000", ["trim", "--points", "3", "--steps", "1000000"])
    case("--points 100000", ["trim", "--points", "100000", "--steps", "99999"])
    case("--jobs 0", ["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "1", "--rows",
                      "root_ahead_m=0.04:0.05:0.01", "--jobs", "0"])
    case("--jobs 100000", ["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "1", "--rows",
                           "root_ahead_m=0.04:0.05:0.01", "--jobs", "100000"])
    case("level --bounds amplitude=60:30", ["level", "--bounds", "amplitude=60:30"])
    case("continue --level --bounds amplitude=70:20", ["continue", "root_ahead_m", "--from", "0.05", "--to", "0.04",
                                                       "--level", "--bounds", "amplitude=70:20"])
    case("level --bounds 60 30 (the old form)", ["level", "--bounds", "60", "30"])
    case("optimize-stability inverted bounds", ["optimize-stability", "--free", "gait.shoulder_sweep.offset_deg",
                                                "--bounds", "gait.shoulder_sweep.offset_deg=10:-10"])
    case("bad input with --json", ["trim", "--json", "--points", "1"])

    # failures reported the documented way
    def not_a_result(text):
        return lambda d: ((d / "run").mkdir(), (d / "run" / "result.json").write_text(text))

    case("plot: result.json is a list", ["plot", "run"], setup=not_a_result("[1, 2]"))
    case("plot: result.json is {}", ["plot", "run"], setup=not_a_result("{}"))
    case("plot: not a folder", ["plot", "nothing-here"])
    case("forces at u = w = 1e300 (non-finite loads)", ["forces", "--state", "1e300", "1e300", "0", "0", "--time", "0",
                                                         "--json"])
    d, _ = case("trim far from any cycle (NaN in IPOPT)", ["trim", *COARSE, "--set",
                                                           "solve.initial_guess=[200.0, 0.0, 0.0, 0.0]", "--out", "run"])
    rows[-1]["note"] = f"solver.log: {sum(1 for _ in open(d / 'run' / 'solver.log'))} CasADi warning lines"
    d, _ = case("grid --jobs 2, every point NaN in IPOPT", ["sweep", "amplitude", "--from", "42", "--to", "43", "--by",
                                                           "1", "--rows", "root_ahead_m=0.04:0.05:0.01", "--jobs", "2",
                                                           "--points", "3", "--steps", "48", "--cold", "--set",
                                                           "solve.initial_guess=[200.0, 0.0, 0.0, 0.0]", "--out", "g"])
    rows[-1]["note"] = f"solver.log: {sum(1 for _ in open(d / 'g' / 'solver.log'))} CasADi warning lines (from the workers)"
    case("sensitivity --json, the cycle fails", ["sensitivity", "--set", "solve.points=3", "--set",
                                                 "solve.steps_per_period=60", "--set",
                                                 "solve.initial_guess=[200.0, 0.0, 0.0, 0.0]", "--json"])

    # outputs and faults: written whole, exit codes independent of stdout, overflow, physical ranges
    d, _ = case("export-c into an earlier export under an 8 kB file-size limit",
                ["export-c", "--steps", "60", "--out", "e", "--json"], setup=earlier_export, preexec=size_limit(8000))
    rows[-1]["note"] = export_intact(d)
    d, _ = case("Ctrl-C while export-c replaces an earlier export", ["export-c", "--steps", "60", "--out", "e", "--json"],
                setup=earlier_export, hook=("birdocp.export.codegen:_write_sources", "1"))
    rows[-1]["note"] = export_intact(d)
    d, _ = case("trim under an 8 kB file-size limit", ["trim", *COARSE, "--out", "run", "--json"],
                preexec=size_limit(8000))
    rows[-1]["note"] = f"run folder left: {(d / 'run').exists()}"
    failing = ["--set", "solve.solver=lm", "--set", "solve.initial_guess=[200.0, 0.0, 0.0, 0.0]", "--out", "run", "--json"]
    for command in (["trim", *COARSE], ["sweep", "amplitude", "--from", "42", "--to", "42", "--by", "1", *COARSE],
                    ["control", "--set", "solve.points=3", "--set", "solve.steps_per_period=60"]):
        for mode in ("broken pipe", "closed"):
            d, _ = case(f"{command[0]} fails, stdout {mode}", [*command, *failing], stdout=mode)
            rows[-1]["note"] = f"result.json written: {(d / 'run' / 'result.json').is_file()}"
    for mode in ("broken pipe", "closed"):
        case(f"forces with non-finite loads, stdout {mode}",
             ["forces", "--state", "1e300", "1e300", "0", "0", "--time", "0", "--json"], stdout=mode)
    sim = ["simulate", "--set", "solve.points=3", "--set", "solve.steps_per_period=60", "--beats", "3", "--json"]
    d, p = case("simulate --gust vertical=60:1 (diverges)", [*sim, "--gust", "vertical=60:1", "--out", "sim"])
    rows[-1]["note"] = f"diverged_beat: {json.loads((d / 'sim' / 'result.json').read_text()).get('diverged_beat')}"
    case("simulate --perturb u=1e308", [*sim, "--perturb", "u=1e308"])
    case("simulate --gust vertical=3:1e-300", [*sim, "--gust", "vertical=3:1e-300"])
    case("simulate --wind vertical=1e300", [*sim, "--wind", "vertical=1e300"])
    case("trim --set body.gravity_mps2=0", ["trim", "--set", "body.gravity_mps2=0", "--json"])
    case("trim --set body.mass_kg=<400 digits>", ["trim", "--set", "body.mass_kg=1" + "0" * 400, "--json"])
    case("optimize-stability --bounds body.mass_kg=-1:2", ["optimize-stability", "--free", "body.mass_kg", "--bounds",
                                                           "body.mass_kg=-1:2"])
    case("control with MPLBACKEND misspelt and PYTHONIOENCODING=ascii, --out k-\u00e9",
         ["control", "--set", "solve.points=3", "--set", "solve.steps_per_period=48", "--out", "k-\u00e9"],
         env={"MPLBACKEND": "no-such-backend", "PYTHONIOENCODING": "ascii"})

    # interrupts
    case("Ctrl-C during the model build", ["trim", *COARSE, "--json", "--out", "run"],
         hook=("birdocp.bird.model:BirdModel.__init__", "1"))
    case("Ctrl-C inside IPOPT (constraint callback)", ["trim", *COARSE, "--json", "--out", "run"],
         hook=("birdocp.engine.oracle:ConstraintOracle.eval", "3"))
    case("Ctrl-C inside the LM solver", ["trim", *COARSE, "--solver", "lm", "--json", "--out", "run"],
         hook=("birdocp.engine.shooting:ShootingGraphs.evaluate", "2"))
    case("Ctrl-C inside IPOPT during level", ["level", *COARSE, "--json", "--out", "run"],
         hook=("birdocp.engine.oracle:ConstraintOracle.eval", "4"))
    d, _ = case("Ctrl-C in a continuation's third step", ["continue", "root_ahead_m", "--from", "0.05", "--to", "0.046",
                                                          "--points", "3", "--steps", "48", "--out", "b", "--quiet",
                                                          "--json"],
                hook=("birdocp.engine.continuation.corrector:Corrector.along", "3"))
    rows[-1]["note"] = (f"branch.json kept with {len(json.loads((d / 'b' / 'branch.json').read_text())['points'])} "
                        "points")
    sweep = ["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "0.5", *COARSE, "--quiet", "--out", "s"]
    d, _ = case("Ctrl-C in a sweep's second point", [*sweep, "--json"],
                hook=("birdocp.engine.oracle:ConstraintOracle.eval", "24"))
    rows[-1]["note"] = f"points on disk: {len(list((d / 's' / 'points').glob('point-*.json')))}"
    p, wall = run([*sweep, "--resume", "--json"], d)
    rows.append(summary("  ... then sweep --resume", p, wall))

    # grid with workers: SIGINT, and SIGKILL of the parent
    grid = ["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "1", "--rows", "root_ahead_m=0.04:0.05:0.005",
            "--jobs", "2", "--points", "3", "--steps", "48", "--out", "g"]
    for sig, name in ((signal.SIGINT, "Ctrl-C"), (signal.SIGKILL, "SIGKILL")):
        d = root / f"c{len(rows):02d}"
        d.mkdir()
        t = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "birdocp", *grid, "--json"], cwd=d, env=ENV,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        workers = []
        while proc.poll() is None and time.perf_counter() - t < 300:
            kids = subprocess.run(["pgrep", "-f", "-P", str(proc.pid), "spawn_main"], capture_output=True,
                                  text=True).stdout.split()
            workers = kids or workers
            if (d / "g" / "rows").is_dir() and list((d / "g" / "rows").glob("row-*.json")):
                break
            time.sleep(0.05)
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=120)
        time.sleep(2.0)
        alive = [w for w in workers if Path(f"/proc/{w}").exists()]
        p = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
        rows.append(summary(f"{name} to a --jobs 2 grid after its first row", p, time.perf_counter() - t,
                            f"workers before {len(workers)}, alive 2 s after {len(alive)}; rows on disk "
                            f"{len(list((d / 'g' / 'rows').glob('row-*.json')))}"))
        print(f"{rows[-1]['exit']:>4}  {rows[-1]['case']}: {rows[-1]['note']}", flush=True)
        p, wall = run([*grid, "--resume", "--json"], d)
        rows.append(summary("  ... then --resume", p, wall))
        print(f"{rows[-1]['exit']:>4}  {rows[-1]['case']}", flush=True)

    # two runs, one folder
    d = root / f"c{len(rows):02d}"
    d.mkdir()
    codes = []
    for attempt in range(3):
        procs = [subprocess.Popen([sys.executable, "-m", "birdocp", "trim", *COARSE, "--out", f"race{attempt}"],
                                  cwd=d, env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                 for _ in range(2)]
        res = [(p.wait(timeout=300), p.stderr.read()) for p in procs]
        codes.append(sorted(c for c, _ in res))
        loser = [e for c, e in res if c == 2]
    rows.append({"case": "two trims started together with one --out (3 times)", "exit": codes,
                 "stderr_lines": len(loser[0].strip().splitlines()) if loser else 0,
                 "last_line": loser[0].strip() if loser else "", "json_status": None, "wall_s": None, "note": ""})
    print(codes, loser[0].strip() if loser else "")

    OUT.mkdir(parents=True, exist_ok=True)
    atomic_write_json(OUT / "hostile_cases.json", rows)
    md = ["| case | exit | JSON status | stderr (last line) | note |", "|---|---|---|---|---|"]
    for r in rows:
        line = r["last_line"].replace("|", "\\|").replace(str(root), "<tmp>")
        md.append(f"| {r['case']} | {r['exit']} | {r['json_status'] or ''} | {line[:160]} | {r['note']} |")
    atomic_write_text(OUT / "hostile_cases.md", "\n".join(md) + "\n")
    print(f"wrote {OUT / 'hostile_cases.md'}")


if __name__ == "__main__":
    main()
