"""Export the bird model as a self-contained C folder (``birdocp export-c``).

The split (``docs/performance.md``): the whole geometry ``data(t, p)`` (214k-480k SX nodes) does not
compile in reasonable time, so it is evaluated here, in Python, on the RK4 stage-time grid of the
configured gait and written as a **table in a generated C file** (``bird_data.c``, a ``static const``
array of ``(2N+1) x N_DATA`` doubles in shortest round-trip decimal, so the values are bit-exact). A
C file rather than a binary file read at start: the folder stays self-contained (no path to find at
run time, no endianness or I/O error path, usable on targets without a file system) and the table
costs a few seconds of compile time once.

What is compiled from CasADi (``bird_casadi.c``, generated):

* ``bird_cg_rhs(x, d, p) -> xdot`` and ``bird_cg_rhs_jac(x, d, p) -> (xdot, dxdot/dx)``;
* ``bird_cg_step(x, D3, p) -> x_next`` (one RK4 step of the fixed size h = T/N, D3 = d at t, t+h/2,
  t+h) and ``bird_cg_step_jac(x, D3, p) -> (x_next, dx_next/dx)``; the step calls the RHS as a
  function (a CasADi call node) instead of inlining it four times, which keeps the C small.

The time loop and the monodromy (product of the step Jacobians) are hand-written C (``bird.c``), not
one giant generated function.

Runtime parameters: only the entries of the model parameter vector that the state RHS depends on
(found from the sparsity of ``d rhs / d p``: mass, pitch inertia, gravity, air density) are inputs of
the C functions; every other parameter (gait, wing geometry, wing root position, lift slope) enters
only through the data table and is baked at export. The export fails if a parameter were both.
"""
from __future__ import annotations

import os
import textwrap
import time
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config
from birdocp.engine.rk4 import rk4_update
from birdocp.engine.stage_grid import stage_time_grid
from birdocp.engine.results import result_dict
from birdocp.io.files import atomic_folder
from birdocp.io.runs import LOCK_NAME

__all__ = ["export_c", "ExportInfo", "runtime_parameters", "EXPORT_FILES"]

EXPORT_FILES = frozenset({"bird_casadi.c", "bird_casadi.h", "bird_data.c", "bird.h", "bird.c", "main.c", "Makefile"})
"""The files of an export (an earlier export's other files, e.g. build products, are kept)."""


@dataclass
class ExportInfo:
    out_dir: Path
    files: list
    steps_per_period: int
    period_s: float
    step_s: float
    n_data: int
    runtime_params: list          # names, in the order of the C vector p
    runtime_p0: list
    baked_params: dict            # name -> value baked in the table
    wall_s: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`; the folder as a string)."""
        return result_dict(self)


def runtime_parameters(model, names=PARAM_NAMES) -> tuple[list[int], list[int]]:
    """(indices the state RHS depends on, indices the data depends on), from Jacobian sparsity
    (``names``: the parameter names, for the message).

    Parameters
    ----------
    model : BirdModel
        Model whose ``rhs`` (state right-hand side) and ``data`` (data table) Functions are exported.
    names : sequence of str
        The parameter names, for the message.

    Returns
    -------
    rhs_indices : list of int
        Parameters the state right-hand side depends on.
    data_indices : list of int
        Parameters the data table depends on; a parameter in both is a ``RuntimeError``.
    """
    r = sorted(set(model.rhs.sparsity_jac(2, 0).get_col()))
    d = sorted(set(model.data.sparsity_jac(1, 0).get_col()))
    both = set(r) & set(d)
    if both:
        raise RuntimeError("parameters used by both the data table and the state RHS cannot be exported: "
                           + ", ".join(names[i] for i in sorted(both)))
    return r, d


def _exported_model(cfg: Config):
    """(model with ``rhs``/``data``, parameter vector, parameter names, period [s]) of ``cfg``: the
    planar model, or with ``model.degrees_of_freedom = 6`` the six-degree-of-freedom model (9 states,
    the lateral inertias appended to the parameters)."""
    if cfg.model.degrees_of_freedom == 6:
        from birdocp.bird.config import param_vector
        from birdocp.bird.sixdof import LATERAL_PARAM_NAMES, LateralInertia, sixdof_model

        six = sixdof_model(cfg)
        p0 = np.asarray(six.params(param_vector(cfg), LateralInertia.of(cfg)), float)
        return six, p0, list(PARAM_NAMES) + list(LATERAL_PARAM_NAMES), float(six.period_s)
    from birdocp.bird.model import get_model

    m = get_model(cfg)
    return m.model, np.asarray(m.p0, float), list(PARAM_NAMES), float(m.period_s)


def _c_ident(name: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in name).upper()


def _functions(model, p0, runtime_idx, h):
    nd = model.rhs.size1_in(1)
    x = ca.SX.sym("x", model.rhs.size1_in(0))
    d = ca.SX.sym("d", nd)
    pr = ca.SX.sym("p", len(runtime_idx))
    pels = [ca.SX(float(v)) for v in p0]
    for k, i in enumerate(runtime_idx):
        pels[i] = pr[k]
    pfull = ca.vertcat(*pels)
    xdot = model.rhs(x, d, pfull)
    rhs = ca.Function("bird_cg_rhs", [x, d, pr], [xdot], ["x", "d", "p"], ["xdot"], {"never_inline": True})
    rhs_jac = ca.Function("bird_cg_rhs_jac", [x, d, pr], [xdot, ca.densify(ca.jacobian(xdot, x))],
                          ["x", "d", "p"], ["xdot", "A"])
    D3 = ca.SX.sym("D3", nd, 3)
    xn = rk4_update(rhs, x, D3, h, pr)[0]
    step = ca.Function("bird_cg_step", [x, D3, pr], [xn], ["x", "D3", "p"], ["x_next"])
    step_jac = ca.Function("bird_cg_step_jac", [x, D3, pr], [xn, ca.densify(ca.jacobian(xn, x))],
                           ["x", "D3", "p"], ["x_next", "J"])
    return [rhs, rhs_jac, step, step_jac]


def _fmt(v: float) -> str:
    return repr(float(v))


def export_c(cfg: Config | None = None, out_dir: str | os.PathLike = "bird_c", *,
             steps_per_period: int | None = None) -> ExportInfo:
    """Write the C folder for ``cfg`` (gait, wing and aero numbers baked into the table) to ``out_dir``.

    ``steps_per_period``: RK4 steps N per period (default ``cfg.solve.steps_per_period``). The period
    map starts at t = 0 (phase zero of the gait), like :func:`birdocp.studies.trim.trim`.

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the paper's reference case).
    out_dir : str or PathLike
        The folder to write (created).
    steps_per_period : int, optional
        See above.

    Returns
    -------
    ExportInfo
        What was written (files, sizes, the parameter table).
    """
    t_all = time.perf_counter()
    cfg = cfg or Config()
    N = int(steps_per_period or cfg.solve.steps_per_period)
    if N < 1:
        raise ValueError(f"steps_per_period must be a positive integer, got {N}")
    model, p0, names, T = _exported_model(cfg)
    h = T / N
    wall = {"model": time.perf_counter() - t_all}
    runtime_idx, data_idx = runtime_parameters(model, names)
    nd = int(model.rhs.size1_in(1))

    t = time.perf_counter()
    times = stage_time_grid(0.0, T, N)
    table = np.asarray(model.data.map(2 * N + 1)(ca.DM(times), ca.DM(p0)))
    if not np.all(np.isfinite(table)):
        raise RuntimeError("the data table has non-finite values for this configuration")
    wall["data_table"] = time.perf_counter() - t

    out = Path(out_dir)
    t = time.perf_counter()
    fns = _functions(model, p0, runtime_idx, h)
    rnames = [names[i] for i in runtime_idx]
    baked = {names[i]: float(p0[i]) for i in data_idx}
    info = ExportInfo(out, [], N, T, h, nd, rnames, [float(p0[i]) for i in runtime_idx], baked, wall)
    # the whole folder at once: written beside ``out`` and put in its place in one step, so an
    # interrupt, a full disk or a size limit leaves the earlier export complete (never a mix of two);
    # files of the earlier folder that are not part of an export (the user's own) are kept
    with atomic_folder(out, carry=lambda name: name not in EXPORT_FILES and name != LOCK_NAME) as tmp:
        gen = ca.CodeGenerator("bird_casadi.c", {"with_header": True})
        for f in fns:
            gen.add(f)
        gen.generate(str(tmp) + os.sep)
        wall["generate_casadi"] = time.perf_counter() - t
        t = time.perf_counter()
        _write_sources(tmp, fns, info, table, p0, runtime_idx, cfg)
        info.files = sorted(p.name for p in tmp.iterdir() if p.is_file())
        wall["write"] = time.perf_counter() - t
    wall["total"] = time.perf_counter() - t_all
    return info


def _write_sources(folder: Path, fns, info: ExportInfo, table, p0, runtime_idx, cfg) -> None:
    """bird_data.c, bird.h, bird.c, main.c and the Makefile into ``folder``."""
    sizes = {key: max(int(getattr(f, attr)()) for f in fns)
             for key, attr in (("@SZ_W@", "sz_w"), ("@SZ_IW@", "sz_iw"), ("@SZ_ARG@", "sz_arg"), ("@SZ_RES@", "sz_res"))}
    sizes["@SZ_IW@"] = max(sizes["@SZ_IW@"], 1)
    bird_c = _BIRD_C
    for key, value in sizes.items():
        bird_c = bird_c.replace(key, str(value))
    _write_data(folder / "bird_data.c", table, p0, runtime_idx, info.steps_per_period, info.period_s, cfg)
    (folder / "bird.h").write_text(_header(info, cfg))
    (folder / "bird.c").write_text(bird_c)
    (folder / "main.c").write_text(_MAIN_C)
    (folder / "Makefile").write_text(_MAKEFILE)


def _write_data(path: Path, table: np.ndarray, p0, runtime_idx, N, T, cfg) -> None:
    vals = np.asarray(table, float).ravel(order="F")  # column k = d at t = k h/2
    lines = [
        "/* Generated by birdocp export-c: the per-time wing data d(t) on the RK4 stage grid. Do not edit. */",
        '#include "bird.h"',
        "",
        "/* bird_data_table[k*BIRD_ND + i] = d_i(t_k), t_k = k*BIRD_STEP_S/2, k = 0..2*BIRD_STEPS. */",
        "const double bird_data_table[BIRD_NCOL * BIRD_ND] = {",
    ]
    for s in range(0, vals.size, 6):
        lines.append("  " + ", ".join(_fmt(v) for v in vals[s:s + 6]) + ",")
    lines.append("};")
    lines.append("")
    lines.append("const double bird_p_default[BIRD_NP] = {"
                 + ", ".join(_fmt(p0[i]) for i in runtime_idx) + "};")
    lines.append("")
    path.write_text("\n".join(lines) + "\n")


def _header(info: ExportInfo, cfg: Config) -> str:
    from birdocp import __version__

    pdoc = "\n".join(f" *   p[{k}] = {n} (default {v!r})" for k, (n, v) in
                      enumerate(zip(info.runtime_params, info.runtime_p0)))
    pdefs = "\n".join(f"#define BIRD_P_{_c_ident(n.split('.')[-1])} {k}  /* {n} */"
                      for k, n in enumerate(info.runtime_params))
    baked = "\n".join(f" *   {n} = {v!r}" for n, v in info.baked_params.items())
    from birdocp.bird.layout import data_blocks
    from birdocp.bird.model import Structure

    st = Structure.of(cfg)
    blocks = []
    k = 0
    for name, (r, c) in data_blocks(st.n_elements):
        blocks.append(f" *   d[{k}..{k + r * c - 1}]  {name} ({r}x{c}, column-major)")
        k += r * c
    if st.wing_mass:  # wings with mass: their sums (birdocp.bird.inertia.MASS_BLOCK)
        from birdocp.bird.inertia import MASS_BLOCK

        blocks += [f" *   d[{k + i}]  {name} (wing masses, body frame)" for i, name in enumerate(MASS_BLOCK)]
        blocks.append(" * With wing masses the RHS adds their inertial forces and moments (docs/studies/inertia.md,"
                      " equations): m is then the whole bird's mass and I the body's own pitch inertia.")
        k += len(MASS_BLOCK)
    if st.aero_extra:  # unsteady / stall section: G, Wx, Wy are per unit circulation, then the unsteady blocks
        from birdocp.bird.unsteady import block_sizes

        blocks.append(" *   (with aero.unsteady/aero.section: G holds K, the downwash per unit circulation, and Wx, Wy"
                      " the induced velocity per unit circulation)")
        for name, r, c in block_sizes(16):
            blocks.append(f" *   d[{k}..{k + r * c - 1}]  {name} ({r}x{c}, column-major; docs/model_unsteady.md)")
            k += r * c
    six = cfg.model.degrees_of_freedom == 6
    if six and st.wing_mass:
        from birdocp.bird.sixdof_inertia import MASS3_BLOCK

        for name, n in MASS3_BLOCK:
            blocks.append(f" *   d[{k}..{k + n - 1}]  {name} (wing masses in 3-D, body frame about G_b; "
                          "birdocp.bird.sixdof_inertia)")
            k += n
    text = HEADER_TEMPLATE.format(
        version=__version__, casadi=ca.__version__, N=info.steps_per_period, T=repr(info.period_s),
        h=repr(info.step_s), nd=info.n_data, ncol=2 * info.steps_per_period + 1,
        np_=len(info.runtime_params), pdefs=pdefs, pdoc=pdoc, baked=baked, blocks="\n".join(blocks),
        freq=repr(cfg.gait.frequency_hz), circ=cfg.aero.circulation, kin=cfg.aero.kinematic_velocity,
        nx=9 if six else 4 + st.n_aero_states, nout=9 if six else 4,
        usage="U V W P Q R PHI THETA PSI" if six else "U W Q THETA")
    if six:
        a, b = text.index(" * MODEL."), text.index(" * TIME.")
        text = text[:a] + _SIX_DOF_MODEL + text[b:]
        text = text.replace("/* states: u, w, q, theta, then the aerodynamic states if any */",
                            "/* states: u, v, w, p, q, r, phi, theta, psi */")
        text = text.replace("xdot[4]", "xdot[9]").replace("row-major 4x4", "row-major 9x9")
        text = text.replace("A[i*4 + j]", "A[i*9 + j]").replace("X[k*4 + i]", "X[k*9 + i]")
    return text


_SIX_DOF_MODEL = """\
 * MODEL. The bird as a rigid body in six degrees of freedom (model.degrees_of_freedom = 6), state
 *   x[0] = u, x[1] = v, x[2] = w  [m/s]    velocity of G along the body axes x' (forward), y' (right),
 *                                          z' (down)
 *   x[3] = p, x[4] = q, x[5] = r  [rad/s]  roll (right wing down), pitch (nose up), yaw (nose right)
 *   x[6] = phi, x[7] = theta, x[8] = psi [rad]  bank, pitch and heading (3-2-1 Euler angles)
 * Newton-Euler in body axes with the lifting line in asymmetric flow (sideslip, roll and yaw rates in
 * every element's velocity), gravity through the attitude, the body's inertia tensor (and, with
 * wing masses, their 3-D inertial terms); the equations are in the documentation (docs/studies/lateral.md).
 *
"""


HEADER_TEMPLATE = """\
/* bird.h -- the birdocp flapping-bird model exported as C (generated by birdocp {version},
 * CasADi {casadi}; do not edit, re-export instead: `birdocp export-c CONFIG --out DIR`).
 *
 * MODEL. Longitudinal rigid-body flight of a bird with flapping wings, state
 *   x[0] = u     [m/s]    velocity of the centre of mass G along the body axis x' (forward)
 *   x[1] = w     [m/s]    velocity of G along the body axis z' (down)
 *   x[2] = q     [rad/s]  pitch rate, positive nose-up
 *   x[3] = theta [rad]    pitch angle of x' above the horizon, positive nose-up
 *   x[4..BIRD_NX-1]       with aero.unsteady = wagner: lag states z1_0..15, z2_0..15 [m/s]; with
 *                         aero.section = dynamic-stall: separation points f_0..15 (docs/model_unsteady.md)
 * Body frame x' forward, z' down, origin G; inertial velocities U = u cos(theta) + w sin(theta)
 * (horizontal), W = u sin(theta) - w cos(theta) (vertical, positive up).
 * xdot = (-q w - g sin(theta) + Fx/m,  q u + g cos(theta) + Fz/m,  My/I,  q), with the
 * aerodynamic loads Fx, Fz [N] and My [N m] about G computed from the wing data d(t) below.
 *
 * TIME. The gait is periodic with period BIRD_PERIOD_S = 1/frequency; t = 0 is phase zero of the
 * gait. The data d(t) is tabulated at the RK4 stage times t_k = k * BIRD_STEP_S / 2,
 * k = 0 .. 2*BIRD_STEPS, for BIRD_STEPS fixed RK4 steps of BIRD_STEP_S per period. Step k (from
 * t = k h to (k+1) h) uses the table columns 2k, 2k+1, 2k+2: bird_stage_data(k).
 *
 * WHAT A C USER CAN VARY AT RUN TIME: the state and the BIRD_NP runtime parameters p[] (the only
 * parameters the state equations depend on; defaults in bird_p_default; units in the names):
{pdoc}
 *
 * WHAT IS BAKED IN (changing any of these needs a re-export, the table depends on them): the gait
 * (frequency {freq} Hz, all joint offsets/amplitudes/phases), the wing geometry, the wing root
 * position, the lift slope, the circulation model ({circ}), the kinematic velocity ({kin}), the
 * number of steps per period and the start phase t = 0. Baked values:
{baked}
 *
 * LAYOUT of one data vector d (BIRD_ND doubles), code frame of the wing model:
{blocks}
 *
 * MATRICES are dense, ROW-MAJOR: A[i*4 + j] = d(out_i)/d(x_j).
 * RETURN VALUES: 0 on success, non-zero if an evaluation failed (bad step index: -1).
 * THREAD SAFETY: all functions use stack work arrays only and are re-entrant.
 */
#ifndef BIRD_H
#define BIRD_H

#ifdef __cplusplus
extern "C" {{
#endif

#define BIRD_NX {nx}              /* states: u, w, q, theta, then the aerodynamic states if any */
#define BIRD_NOUT {nout}            /* states printed by the example main.c */
#define BIRD_STATE_USAGE "{usage}"
#define BIRD_ND {nd}           /* data vector length */
#define BIRD_NP {np_}              /* runtime parameters */
#define BIRD_STEPS {N}           /* RK4 steps per period */
#define BIRD_NCOL {ncol}            /* table columns, 2*BIRD_STEPS + 1 */
#define BIRD_PERIOD_S {T}      /* period [s] */
#define BIRD_STEP_S {h}   /* RK4 step h = BIRD_PERIOD_S / BIRD_STEPS [s] */

/* indices into the runtime parameter vector p */
{pdefs}

extern const double bird_data_table[BIRD_NCOL * BIRD_ND];  /* column k = d(k h/2) */
extern const double bird_p_default[BIRD_NP];               /* the exported configuration's p */

/* d(t) at the stage time t_k = k h/2 (k = 0..BIRD_NCOL-1); NULL if k is out of range. */
const double *bird_data(int k);

/* The three columns [d(kh), d(kh + h/2), d(kh + h)] used by RK4 step k (k = 0..BIRD_STEPS-1),
 * contiguous BIRD_ND x 3 (column-major), as the D3 argument below; NULL if k is out of range. */
const double *bird_stage_data(int k);

/* State equations: xdot[4] = f(x, d, p) (units of x per second). */
int bird_rhs(const double x[BIRD_NX], const double d[BIRD_ND], const double p[BIRD_NP],
             double xdot[BIRD_NX]);

/* State equations and their Jacobian A = d xdot / d x [1/s, mixed units], row-major 4x4. */
int bird_rhs_jac(const double x[BIRD_NX], const double d[BIRD_ND], const double p[BIRD_NP],
                 double xdot[BIRD_NX], double A[BIRD_NX * BIRD_NX]);

/* One RK4 step of size BIRD_STEP_S: x_next = x(t + h) from x(t), D3 = bird_stage_data(k). */
int bird_step(const double x[BIRD_NX], const double *D3, const double p[BIRD_NP],
              double x_next[BIRD_NX]);

/* One RK4 step and its state Jacobian J = d x_next / d x, row-major 4x4 (dimensionless
 * in consistent units). */
int bird_step_jac(const double x[BIRD_NX], const double *D3, const double p[BIRD_NP],
                  double x_next[BIRD_NX], double J[BIRD_NX * BIRD_NX]);

/* One period from t = 0: x_T = Phi(x0) after BIRD_STEPS RK4 steps. If M is not NULL it receives the
 * monodromy M = d x_T / d x0 (row-major 4x4, the product of the step Jacobians; its eigenvalues
 * are the Floquet multipliers when x0 is on the periodic orbit). If X is not NULL it receives the
 * states after each step, X[k*4 + i] = x_i((k+1) h), k = 0..BIRD_STEPS-1. */
int bird_period(const double x0[BIRD_NX], const double p[BIRD_NP], double x_T[BIRD_NX],
                double M[BIRD_NX * BIRD_NX], double *X);

#ifdef __cplusplus
}}
#endif
#endif /* BIRD_H */
"""

_BIRD_C = """\
/* bird.c -- RK4 time loop and monodromy around the CasADi-generated functions (bird_casadi.c).
 * Generated by birdocp export-c; see bird.h for the documentation. */
#include <string.h>
#include "bird.h"
#include "bird_casadi.h"

#define SZ_W @SZ_W@
#define SZ_IW @SZ_IW@
#define SZ_ARG @SZ_ARG@
#define SZ_RES @SZ_RES@

typedef int (*cg_fn)(const casadi_real **, casadi_real **, casadi_int *, casadi_real *, int);

static int call(cg_fn f, const double *a0, const double *a1, const double *a2, double *r0, double *r1) {
  const casadi_real *arg[SZ_ARG];
  casadi_real *res[SZ_RES];
  casadi_int iw[SZ_IW];
  casadi_real w[SZ_W];
  memset(arg, 0, sizeof arg);
  memset(res, 0, sizeof res);
  arg[0] = a0; arg[1] = a1; arg[2] = a2;
  res[0] = r0;
  if (SZ_RES > 1) res[1] = r1;
  return f(arg, res, iw, w, 0);
}

/* CasADi returns dense column-major; the API is row-major. */
static void to_row_major(const double *cm, double *rm) {
  int i, j;
  for (i = 0; i < BIRD_NX; ++i)
    for (j = 0; j < BIRD_NX; ++j) rm[i * BIRD_NX + j] = cm[i + BIRD_NX * j];
}

const double *bird_data(int k) {
  if (k < 0 || k >= BIRD_NCOL) return 0;
  return bird_data_table + (long)k * BIRD_ND;
}

const double *bird_stage_data(int k) {
  if (k < 0 || k >= BIRD_STEPS) return 0;
  return bird_data_table + (long)(2 * k) * BIRD_ND;
}

int bird_rhs(const double x[BIRD_NX], const double d[BIRD_ND], const double p[BIRD_NP], double xdot[BIRD_NX]) {
  return call(bird_cg_rhs, x, d, p, xdot, 0);
}

int bird_rhs_jac(const double x[BIRD_NX], const double d[BIRD_ND], const double p[BIRD_NP],
                 double xdot[BIRD_NX], double A[BIRD_NX * BIRD_NX]) {
  double cm[BIRD_NX * BIRD_NX];
  int rc = call(bird_cg_rhs_jac, x, d, p, xdot, cm);
  if (rc == 0) to_row_major(cm, A);
  return rc;
}

int bird_step(const double x[BIRD_NX], const double *D3, const double p[BIRD_NP], double x_next[BIRD_NX]) {
  if (!D3) return -1;
  return call(bird_cg_step, x, D3, p, x_next, 0);
}

int bird_step_jac(const double x[BIRD_NX], const double *D3, const double p[BIRD_NP],
                  double x_next[BIRD_NX], double J[BIRD_NX * BIRD_NX]) {
  double cm[BIRD_NX * BIRD_NX];
  int rc;
  if (!D3) return -1;
  rc = call(bird_cg_step_jac, x, D3, p, x_next, cm);
  if (rc == 0) to_row_major(cm, J);
  return rc;
}

int bird_period(const double x0[BIRD_NX], const double p[BIRD_NP], double x_T[BIRD_NX],
                double M[BIRD_NX * BIRD_NX], double *X) {
  double x[BIRD_NX], xn[BIRD_NX], J[BIRD_NX * BIRD_NX], Mk[BIRD_NX * BIRD_NX], Mn[BIRD_NX * BIRD_NX];
  int k, i, j, l, rc;
  memcpy(x, x0, sizeof x);
  for (i = 0; i < BIRD_NX * BIRD_NX; ++i) Mk[i] = (i % (BIRD_NX + 1) == 0) ? 1.0 : 0.0;
  for (k = 0; k < BIRD_STEPS; ++k) {
    if (M) {
      rc = bird_step_jac(x, bird_stage_data(k), p, xn, J);
      if (rc) return rc;
      for (i = 0; i < BIRD_NX; ++i)       /* Mk <- J Mk */
        for (j = 0; j < BIRD_NX; ++j) {
          double s = 0.0;
          for (l = 0; l < BIRD_NX; ++l) s += J[i * BIRD_NX + l] * Mk[l * BIRD_NX + j];
          Mn[i * BIRD_NX + j] = s;
        }
      memcpy(Mk, Mn, sizeof Mk);
    } else {
      rc = bird_step(x, bird_stage_data(k), p, xn);
      if (rc) return rc;
    }
    memcpy(x, xn, sizeof x);
    if (X) memcpy(X + (long)k * BIRD_NX, x, sizeof x);
  }
  memcpy(x_T, x, sizeof x);
  if (M) memcpy(M, Mk, sizeof Mk);
  return 0;
}
"""

_MAIN_C = """\
/* main.c -- example: one period of the exported bird model from a state given on the command line.
 *   ./bird_period U W Q THETA [AERODYNAMIC STATES] [P0 P1 ...]
 * (u [m/s], w [m/s], q [rad/s], theta [rad], then the BIRD_NX - 4 aerodynamic states of an unsteady or
 * dynamic-stall model; optional runtime parameters in the order of bird.h).
 * Prints the state after one period (one line, 4 numbers) and then the monodromy d x_T / d x0,
 * row by row (4 lines of 4 numbers). Exit 2 on bad arguments, 1 if an evaluation failed. */
#include <stdio.h>
#include <stdlib.h>
#include "bird.h"

static int parse(const char *s, double *v) {
  char *end;
  *v = strtod(s, &end);
  return end != s && *end == '\\0';
}

int main(int argc, char **argv) {
  double x0[BIRD_NX], xT[BIRD_NX], M[BIRD_NX * BIRD_NX], p[BIRD_NP];
  int i, j;
  if (argc != 1 + BIRD_NX && argc != 1 + BIRD_NX + BIRD_NP) {
    fprintf(stderr, "usage: %s " BIRD_STATE_USAGE " [+%d aerodynamic states] [%d runtime parameters, see bird.h]\\n",
            argv[0], BIRD_NX - BIRD_NOUT, BIRD_NP);
    return 2;
  }
  for (i = 0; i < BIRD_NX; ++i)
    if (!parse(argv[1 + i], &x0[i])) { fprintf(stderr, "%s: not a number: %s\\n", argv[0], argv[1 + i]); return 2; }
  for (i = 0; i < BIRD_NP; ++i) {
    p[i] = bird_p_default[i];
    if (argc == 1 + BIRD_NX + BIRD_NP && !parse(argv[1 + BIRD_NX + i], &p[i])) {
      fprintf(stderr, "%s: not a number: %s\\n", argv[0], argv[1 + BIRD_NX + i]);
      return 2;
    }
  }
  if (bird_period(x0, p, xT, M, NULL)) { fprintf(stderr, "%s: evaluation failed\\n", argv[0]); return 1; }
  for (i = 0; i < BIRD_NOUT; ++i) printf(i ? " %.17g" : "%.17g", xT[i]);
  printf("\\n");
  for (i = 0; i < BIRD_NX; ++i) {
    for (j = 0; j < BIRD_NX; ++j) printf(j ? " %.17g" : "%.17g", M[i * BIRD_NX + j]);
    printf("\\n");
  }
  return 0;
}
"""

_MAKEFILE = textwrap.dedent("""\
    # Makefile for the exported bird model (generated by birdocp export-c).
    #   make            -> bird_period (example) and libbird.a
    #   make libbird.so -> shared library
    # -O1: the generated straight-line code gains little from -O2 and builds slower; -O0 is slow.
    CC ?= cc
    CFLAGS ?= -O1
    CFLAGS += -fPIC
    LDLIBS = -lm
    OBJ = bird_casadi.o bird.o bird_data.o

    all: bird_period libbird.a

    bird_period: main.o libbird.a
    \t$(CC) $(CFLAGS) -o $@ main.o libbird.a $(LDLIBS)

    libbird.a: $(OBJ)
    \t$(AR) rcs $@ $(OBJ)

    libbird.so: $(OBJ)
    \t$(CC) $(CFLAGS) -shared -o $@ $(OBJ) $(LDLIBS)

    bird_data.o: bird_data.c bird.h
    \t$(CC) $(CFLAGS) -O0 -c bird_data.c

    %.o: %.c bird.h bird_casadi.h
    \t$(CC) $(CFLAGS) -c $<

    clean:
    \trm -f *.o libbird.a libbird.so bird_period

    .PHONY: all clean
    """)
