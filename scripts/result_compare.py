"""Compare two result JSON documents number by number (standard library only; used by
``scripts/check_results.py`` and its test).

Rules:

- integers, strings, booleans and ``None`` must be equal (a bool is never a number here);
- two floats (or a float and an integer) are equal within a relative tolerance: ``|a - b| <= rtol *
  max(|a|, |b|) + atol`` (default ``rtol`` 1e-9, ``atol`` 1e-14: below that a number is a round-off zero
  of an order-one quantity); two NaNs are equal;
- in a list of numbers (a vector, or a list of vectors such as multipliers ``[re, im]``), the tolerance
  is relative to the list's largest magnitude (a multiplier of 1e-18 beside one of 1 is zero);
- numbers written inside strings (a solver message such as ``max|g| = 3.983e-12``) are compared with
  the noise tolerance below, as they are printed rounded to a few digits; the rest of the string exactly;
- a key whose name says it is a timing, a host or a provenance record (:data:`IGNORED_KEY`: wall or CPU
  seconds, load average, dates, versions, revisions, host names, the run folder's path) is skipped with everything below it;
- so is a count of solver work (:data:`EFFORT_KEY`: ``iterations``, ``evaluations``), and such a count
  written in a sentence (``337 iterations``) is left out of the sentence's comparison;
- a per-key override (``{regex: (rtol, atol)}``, the regex matched against the key's name) replaces the
  tolerances for that key and everything below it, for solver-noise quantities (residuals, error
  estimates) whose value is only meaningful as "below the tolerance";
- an eigenvector (``eigenvector`` key) is compared up to a unit complex factor (its sign for a real
  mode), which its normalisation leaves to round-off;
- dictionaries must have the same keys (ignored keys aside), lists the same length;
- in the results of the scripts registered ``unconverged=True`` (whose failed solves were measured to
  move with the solver's path), a solve that did not converge (a dictionary with a ``status``, or whose
  ``optimum`` has one, that is an iteration cap, :data:`ITERATION_CAP`, or comes with ``success`` False)
  is compared by its keys, by what it is and by the fact that it failed (:data:`STATEMENT_KEY`: problem,
  model, start, cap, grid, ``success``); not by how it failed nor by what it found: its last iterate is a
  point of the path, which a re-run moves (docs/reproducibility.md), and so is everything computed at it
  (what the docs cite such an iterate for is re-solved from its committed gait by
  ``scripts/iterate_claims.py`` and compared by its numbers);
- an optimum's ``verification`` block (its cycle trimmed again) differs from the optimum by the optimum's
  own error: its numbers to 1e-5 absolute (:data:`VERIFIED`) on top of the relative tolerance;
- a text result (a Markdown table such as ``optimized.md``, rendered from a JSON result compared by the
  rules above) is compared line by line (:func:`compare_text`), each line as a sentence: its numbers, printed
  rounded, within the noise tolerance, ``N iterations`` left out, the rest exactly; for an ``unconverged`` script,
  a line about a solve stopped by its cap (:data:`CAP_IN_TEXT` in both) by what it says the solve is (a
  table row's cells up to the one naming the cap, a sentence's words before its colon).

A difference is reported as ``(path, committed, regenerated)``; ``path`` is a ``/``-separated list of keys
and list indices.
"""
from __future__ import annotations

import math
import re

#: Keys that record how, where or how fast a result was produced, not what it is.
IGNORED_KEY = re.compile(
    r"(wall|cpu_s|cpu_total|cpu_count|cpus$|load_?average|load_1min|uptime|timestamp|hostname|^machine$"
    r"|^date$|^python(_version)?$|^casadi(_version)?$|_version$|^version$|revision|^git$|^commit$"
    r"|^provenance$|^run_dir$|speedup|warmup|_call_s$|^time_per_iteration_s$|^(cold_)?(solve|total)_s$|^floquet_s$"
    r"|^build_s$|^compile_s$|cpu_ratio|^first_solve|^reference_wall_s$|^with_error_estimate_s$)",
    re.IGNORECASE)

#: Round-off-dominated quantities: differences of nearly equal numbers (residuals, error estimates,
#: distances between two solutions (``a_vs_b`` keys), the trivial multiplier's distance to 1, and the
#: observed convergence order, a ratio of logarithms of such errors). A change of one unit in the
#: last place of the operands changes them by ~1e-16 in absolute terms, i.e. by a large relative amount;
#: they are compared to 1e-2 relative or 1e-11 absolute (an error estimate of 1.8190e-8 against
#: 1.8191e-8, a KKT residual of 2.474e-8 against 2.482e-8, are the same statement; 1.8e-8 against
#: 2.0e-8 is flagged).
NOISE = (1e-2, 1e-11)
#: Lyapunov exponents of a chaotic trajectory (and their standard errors) are statistics of a
#: trajectory that round-off changes after a few Lyapunov times: compared to 0.03 absolute, about three
#: times the largest standard error the examples report (0.0096 1/s).
CHAOS = (0.0, 0.03)
#: The default per-key overrides (regex on the key's name -> (rtol, atol)).
#: Quantities derived through the logarithm of a multiplier that may be far below 1 (``beats_to_double``
#: of a mode with |Lambda| ~ 1e-10: the multiplier's round-off, 1e-16 absolute, is a 1e-6 relative
#: change of |Lambda| and ~5e-8 of its logarithm): 1e-6 relative. Two values both within
#: :data:`ZERO_MULTIPLIER_BEATS` of 0 belong to multipliers below 2**-33 ~ 1e-10 beside multipliers of
#: order one, i.e. numerical zeros of the monodromy (one may even be exactly 0, beats_to_double 0.0):
#: equal.
LOG_OF_MULTIPLIER = (1e-6, 0.0)
ZERO_MULTIPLIER_BEATS = 0.03
#: An optimum's ``verification`` block (its cycle trimmed again independently, from another start): the
#: re-trimmed cycle differs from the optimum's by the optimum's own error, its constraint violation (~1e-8)
#: times the cycle's conditioning; measured at a fold, for one optimum equal to 1e-8 on two versions of the
#: code: a state difference 1.47e-7 and 1.84e-7, a power difference -7.2e-7 and 9.0e-7 W, a mean vertical
#: speed -6e-8 and 8e-8 m/s, and the imaginary part of a nearly real multiplier pair 0.0029679 and
#: 0.0029660 (a pair next to its collision amplifies the error). Every number of the block is compared to
#: 1e-5 absolute on top of the optimum's relative tolerance (states in m/s, rad/s, powers in W, multipliers).
VERIFIED = (0.0, 1e-5)
#: What is zero by the mirror symmetry of a symmetric gait (the lateral states of its cycle, the coupling
#: blocks of its monodromy) is zero to the solve's tolerance, 1e-10: measured, the `wagner` +
#: `dynamic-stall` 6-DOF cycle's lateral states 2.8e-12 and 3.7e-11 on two versions of the code.
SYMMETRY_ZERO = (0.0, 1e-10)
#: The shares of an eigenvector in the body or lateral states: a change of the cycle at the solver's
#: tolerance moves the eigenvector of a multiplier in a cluster (the aerodynamic modes, 0.12-0.15 a few
#: hundredths apart) by that change over the gap: measured 4.7e-9 relative between two versions of the code.
EIGENVECTOR_SHARE = (1e-7, 0.0)
OVERRIDES = {r"^verification$": VERIFIED, r"coupling_max$|^max_abs_lateral": SYMMETRY_ZERO,
             r"^(body|lateral)_share$": EIGENVECTOR_SHARE, r"lyapunov": CHAOS, r"beats_to_double|doubling_time|halving_time": LOG_OF_MULTIPLIER,
             r"residual|error|difference|distance|_vs_|^solver$|^relative(_solver)?$|kkt|violation"
             r"|observed_order|^test_value$": NOISE}
#: Keys holding an eigenvector as ``[re, im]`` pairs: compared after scaling the regenerated one by the
#: unit complex factor (a sign, for a real mode) that matches its largest component to the committed
#: one's, as an eigenvector normalised by its largest magnitude keeps LAPACK's arbitrary sign or phase.
EIGENVECTOR_KEYS = ("eigenvector", "eigenvectors")
#: The statuses of a solve stopped by its iteration cap (IPOPT's, with or without its prefix, and the
#: engine's). Its last iterate depends on the path: a change of 1e-13 in the gradients moved a
#: 60-iteration SR1 iterate from r 0.940 to 0.710 and an 8-iteration exact-Hessian one by 2e-6
#: (docs/reproducibility.md).
ITERATION_CAP = re.compile(r"^(?:IPOPT: )?(?:Maximum_Iterations_Exceeded|max_iter)$")
#: What a solve that did not converge is compared by (at its own level and its ``optimum``'s): what it
#: is (problem, model, start, cap, grid) and that it failed (``success``). Not how it failed (its status:
#: a failed start of the 16-start design of stability_optimum/valid ended Infeasible_Problem_Detected,
#: then Maximum_Iterations_Exceeded, then Infeasible_Problem_Detected again in three sessions), nor what
#: it found: its numbers, its validity, the cycles solved at it. Measured: the same command moved the
#: tailless stall optimiser's 10-iteration iterate from r 1.0074 to 1.0782, the level cycle at its gait
#: from |Lambda1| 0.986 (stable) to 1.067, the tail's 60-iteration SR1 iterate to a gait whose 148-step
#: level flight fails (it converged at the committed one), the speed-free SR1 stage took two validity
#: rounds instead of one, and the unreachable 10 m/s point of the valid power curve (100 iterations, KKT
#: 2e24) ended at 5.393 W instead of 5.358 W.
STATEMENT_KEY = re.compile(r"^(gait|case|label|hessian|start|started_from|inserted|max_iter|steps_per_period"
                           r"|overrides|problem|model|quasi_steady_radius|speed_mps|success)$")
#: A Markdown line about a capped solve (its status, or the marker the scripts print beside its label).
CAP_IN_TEXT = re.compile(r"Maximum_Iterations_Exceeded|\bmax_iter\b|iteration cap")
NUMBER_IN_TEXT = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


#: Keys that count a solver's work (its iterations, its oracle evaluations, ``*_evaluations``): like a timing they say how
#: the result was reached, not what it is, and round-off changes them with the result unchanged
#: (measured: the same code and inputs gave 10 and 9 full evaluations of the finite-difference Hessian's
#: thread pool on two runs, and IPOPT reached one tail optimum in 85 and 115 iterations before and after
#: a change of the last bits of the Jacobians, the optimum equal to 1e-9).
EFFORT_KEY = re.compile(r"^(iterations|n_iter|nfev|njev)$|evaluations$", re.IGNORECASE)
#: The same counts written inside a sentence (``"coarse stage (32 steps): Solve_Succeeded, 337 iterations"``).
EFFORT_IN_TEXT = re.compile(r"\b\d+(?= (?:iterations|evaluations|it\.)\b)")


def is_ignored(key: str) -> bool:
    """True when ``key`` names a timing, host or provenance record, or a count of solver work."""
    return bool(IGNORED_KEY.search(str(key)) or EFFORT_KEY.search(str(key)))


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _close(a: float, b: float, rtol: float, atol: float) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= rtol * max(abs(a), abs(b)) + atol


def _tolerance(key, tol, overrides):
    """The tolerance below ``key``: an override only loosens the one inherited from the parents."""
    for pattern, t in overrides.items():
        if re.search(pattern, str(key)):
            return max(tol[0], t[0]), max(tol[1], t[1])
    return tol


def compare(old, new, rtol: float = 1e-9, atol: float = 1e-14, overrides: dict | None = None,
            limit: int = 20, unconverged_statements: bool = False) -> list[tuple[str, object, object]]:
    """The differences between the committed ``old`` and the regenerated ``new`` (at most ``limit``),
    each ``(path, old value, new value)``; ``[]`` when they agree. ``overrides`` defaults to
    :data:`OVERRIDES` (``{}`` for none). With ``unconverged_statements`` (a registry entry's ``unconverged``:
    the scripts whose failed solves were measured to move with the solver's path), a solve that did not
    converge is compared by its statements (:func:`unconverged`, :data:`STATEMENT_KEY`)."""
    overrides = OVERRIDES if overrides is None else overrides
    out: list = []
    _walk(old, new, "", (rtol, atol), overrides, out, limit, unconverged_statements)
    return out


def _pairs(v) -> list | None:
    """A dict or list of ``[re, im]`` pairs as a list of complex numbers (keys sorted), else None."""
    items = [v[k] for k in sorted(v)] if isinstance(v, dict) else v if isinstance(v, list) else None
    if not items or not all(isinstance(x, list) and len(x) == 2 and all(_number(y) for y in x) for x in items):
        return None
    return [complex(x[0], x[1]) for x in items]


def _rephased(a, b):
    """``b`` multiplied by the unit complex factor that makes its largest component ``a``'s (an
    eigenvector is defined up to such a factor), in ``b``'s layout; ``b`` itself when not an eigenvector."""
    ca, cb = _pairs(a), _pairs(b)
    if ca is None or cb is None or len(ca) != len(cb):
        return b
    k = max(range(len(ca)), key=lambda i: abs(ca[i]))
    if cb[k] == 0 or not math.isclose(abs(ca[k]), abs(cb[k]), rel_tol=1e-6):
        return b
    f = ca[k] / cb[k]
    f /= abs(f)
    keys = sorted(b) if isinstance(b, dict) else range(len(b))
    new = [[(z * f).real, (z * f).imag] for z in cb]
    return dict(zip(keys, new)) if isinstance(b, dict) else new


def _walk(a, b, path, tol, overrides, out, limit, cap=False) -> None:
    if len(out) >= limit:
        return
    if path.rsplit("/", 1)[-1] in EIGENVECTOR_KEYS:
        b = _rephased(a, b)
    if cap and isinstance(a, dict) and isinstance(b, dict) and (unconverged(a) or unconverged(b)):
        _compare_unconverged(a, b, path, tol, overrides, out, limit)
    elif isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            if is_ignored(k):
                continue
            p = f"{path}/{k}"
            if k not in b or k not in a:
                out.append((p, a.get(k, "<missing>"), b.get(k, "<missing>")))
            else:
                _walk(a[k], b[k], p, _tolerance(k, tol, overrides), overrides, out, limit, cap)
            if len(out) >= limit:
                return
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append((f"{path}/len", len(a), len(b)))
            return
        scale = _scale(a)
        t = tol if scale is None else (tol[0], max(tol[1], tol[0] * scale))
        for i, (x, y) in enumerate(zip(a, b)):
            _walk(x, y, f"{path}/{i}", t, overrides, out, limit, cap)
    elif _number(a) and _number(b) and (isinstance(a, float) or isinstance(b, float)):
        zero = path.endswith("/beats_to_double") and max(abs(a), abs(b)) < ZERO_MULTIPLIER_BEATS
        if not zero and not _close(float(a), float(b), *tol):
            out.append((path, a, b))
    elif isinstance(a, str) and isinstance(b, str):
        if a != b and not _same_text(a, b):
            out.append((path, a, b))
    elif type(a) is not type(b) or a != b:
        out.append((path, a, b))


def unconverged(d) -> bool:
    """True when ``d`` records a solve that did not converge: it has a ``status`` (or its ``optimum`` has)
    and that is an iteration cap (:data:`ITERATION_CAP`) or comes with ``success`` False."""
    return any(isinstance(x.get("status"), str) and (x.get("success") is False or bool(ITERATION_CAP.match(x["status"])))
               for x in _records(d))


def _records(d) -> list[dict]:
    """The solve records of ``d``: itself and its ``optimum`` (when a dictionary); none for a non-dict."""
    if not isinstance(d, dict):
        return []
    return [d] + ([d["optimum"]] if isinstance(d.get("optimum"), dict) else [])


def _compare_unconverged(a: dict, b: dict, path: str, tol, overrides, out: list, limit: int) -> None:
    """Compare two solves that did not converge (:func:`unconverged`) by their keys and their statements
    (the :data:`STATEMENT_KEY` entries of the solve and of its ``optimum``, each by the usual rules); a
    status difference when only one did not converge."""
    if not (unconverged(a) and unconverged(b)):
        out.append((f"{path}/status", _status(a), _status(b)))
        return
    ka, kb = [k for k in a if not is_ignored(k)], [k for k in b if not is_ignored(k)]
    out += [(f"{path}/{k}", a.get(k, "<missing>"), b.get(k, "<missing>")) for k in ka + kb
            if (k in a) != (k in b)]
    pairs = [(f"{path}/{k}", k, a[k], b[k]) for k in ka if k in b and STATEMENT_KEY.match(str(k))]
    oa, ob = a.get("optimum"), b.get("optimum")
    if isinstance(oa, dict) and isinstance(ob, dict):
        pairs += [(f"{path}/optimum/{k}", k, oa[k], ob[k]) for k in oa if k in ob and STATEMENT_KEY.match(str(k))]
    for p, k, x, y in pairs:
        _walk(x, y, p, _tolerance(k, tol, overrides), overrides, out, limit)
    del out[limit:]


def _status(d: dict):
    """The status of a solve or, when it has none, of its optimum."""
    return next((x["status"] for x in _records(d) if "status" in x), None)


def _scale(v) -> float | None:
    """The largest magnitude of a list of numbers or of a list of lists of numbers, else None."""
    flat = [y for x in v for y in (x if isinstance(x, list) else [x])]
    if not flat or not all(_number(x) for x in flat):
        return None
    finite = [abs(float(x)) for x in flat if math.isfinite(float(x))]
    return max(finite) if finite else None


def _same_text(a: str, b: str) -> bool:
    """Two sentences (with a space: not hashes or names) equal once their numbers are compared with
    :data:`NOISE`."""
    if " " not in a:
        return False
    a, b = EFFORT_IN_TEXT.sub("", a), EFFORT_IN_TEXT.sub("", b)
    if NUMBER_IN_TEXT.sub("#", a) != NUMBER_IN_TEXT.sub("#", b):
        return False
    na, nb = NUMBER_IN_TEXT.findall(a), NUMBER_IN_TEXT.findall(b)
    return all(_close(float(x), float(y), *NOISE) for x, y in zip(na, nb))


def compare_text(old: str, new: str, limit: int = 20, unconverged_statements: bool = False) -> list[tuple[str, object, object]]:
    """The differences between a committed text result ``old`` and the regenerated ``new`` (at most
    ``limit``), each ``("line N", old line, new line)`` (``("lines", n_old, n_new)`` when their numbers of
    lines differ); a line agrees when equal or equal as a sentence (:func:`_same_text`), or, with
    ``unconverged_statements``, about a solve stopped by its iteration cap (:data:`CAP_IN_TEXT` in both), when
    what it says the solve is agrees (:func:`_same_words`)."""
    a, b = old.splitlines(), new.splitlines()
    out: list = [("lines", len(a), len(b))] if len(a) != len(b) else []
    out += [(f"line {i + 1}", x, y) for i, (x, y) in enumerate(zip(a, b)) if x != y and not _same_text(x, y)
            and not (unconverged_statements and _same_words(x, y))]
    return out[:limit]


def _same_words(a: str, b: str) -> bool:
    """Two lines about a capped solve (:data:`CAP_IN_TEXT` in both) agree when what they say the solve
    *is* agrees: a table row's cells up to the one naming the cap (problem, model, start, grid, status), a
    sentence's words before its colon; what the iterate found is compared in the JSON (its statements)."""
    return bool(CAP_IN_TEXT.search(a) and CAP_IN_TEXT.search(b)) and _cap_head(a) == _cap_head(b)


def _cap_head(t: str):
    """The cells of a table row up to the first naming the cap, or a sentence's words before its colon."""
    if not t.lstrip().startswith("|"):
        return t.split(":")[0]
    cells = [c.strip() for c in t.strip().strip("|").split("|")]
    i = next((i for i, c in enumerate(cells) if CAP_IN_TEXT.search(c)), len(cells) - 1)
    return cells[:i + 1]


def relative_gap(a, b) -> float | None:
    """``|a - b| / max(|a|, |b|)`` for two numbers (``None`` otherwise): how far apart a difference is."""
    if not (_number(a) and _number(b)):
        return None
    m = max(abs(a), abs(b))
    return 0.0 if m == 0 else abs(a - b) / m
