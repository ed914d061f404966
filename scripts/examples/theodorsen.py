"""Theodorsen's function from birdocp's unsteady lifting line (the 2-D limit, docs/model_unsteady.md).

A rectangular wing of 16 lifting-line elements (aspect ratio 1e4, chord 0.2 m, stream 18 m/s, the
body held) pitches about its quarter chord by 0.1 deg at reduced frequency K = omega c / (2 U) with
``aero.unsteady = "wagner"``; the first harmonic of the mid-span element's circulatory lift over the
quasi-steady one, pi rho c U Q (Q the normalwash at the 3/4-chord point), is the implemented transfer
function. It is compared with Jones's approximation C_J(k) (the model's indicial response) and
Theodorsen's exact C(k) (scipy's Hankel functions, when scipy is installed).

    python scripts/examples/theodorsen.py --k 0.14 --out results/aero/theodorsen

Writes DIR/result.json (``transfer_function``, ``transfer_function_2d`` (a strip without trailing
wake), ``jones``, ``exact``: [re, im]; ``exact`` null without scipy) and DIR/theodorsen.png: |C| and
phase against k, exact, Jones and implemented (2-D strip over k, the 16-element wing at K).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
RHO, U, C = 1.225, 18.0, 0.2


def exact(k: float):
    """Theodorsen's C(k) = H1(2)(k) / (H1(2)(k) + i H0(2)(k)), or None without scipy."""
    try:
        from scipy.special import hankel2
    except ImportError:
        return None
    h1, h0 = hankel2(1, k), hankel2(0, k)
    return complex(h1 / (h1 + 1j * h0))


def implemented(k: float, aspect_ratio, n: int) -> complex:
    """First harmonic of the circulatory lift over pi rho c U Q (pitch about the quarter chord)."""
    from birdocp.bird.unsteady_harness import PrescribedWing, first_harmonic, harmonic

    amp = math.radians(0.1)
    wing = PrescribedWing("wagner", "linear", chord_m=C, speed_mps=U, aspect_ratio=aspect_ratio, n=n)
    kin, om, T = harmonic(k, U, C, pitch_rad=amp)
    r = wing.periodic(kin, T, steps=400, newton=1 if n > 2 else 2)
    Q = U * (-1j * amp) + (C / 2) * (om * amp)   # U theta - h' + (c/2) theta' (complex amplitude)
    return complex(first_harmonic(r["t_s"], r["lift_circulatory_Npm"], om) / (math.pi * RHO * C * U * Q))


def pair(z):
    return None if z is None else [float(z.real), float(z.imag)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument("--k", type=float, default=0.14, help="reduced frequency omega c / (2 U) (default 0.14)")
    ap.add_argument("--out", default=str(ROOT / "results" / "aero" / "theodorsen"),
                    help="output folder (default results/aero/theodorsen)")
    args = ap.parse_args(argv)
    if not (math.isfinite(args.k) and 0.005 <= args.k <= 5.0):
        print(f"theodorsen.py: --k must be a reduced frequency in [0.005, 5], got {args.k!r}", file=sys.stderr)
        return 2
    from birdocp.bird.unsteady import jones_transfer
    from birdocp.io.files import atomic_write_json

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    k = float(args.k)
    tf = implemented(k, 1e4, 16)
    tf2 = implemented(k, None, 2)
    ks = np.geomspace(0.02, 2.0, 25)
    curve = [implemented(float(x), None, 2) for x in ks]
    res = {"k": k, "transfer_function": pair(tf), "transfer_function_2d": pair(tf2),
           "jones": pair(jones_transfer(k)), "exact": pair(exact(k)),
           "abs_error_vs_jones": abs(tf - jones_transfer(k)),
           "abs_error_vs_exact": None if exact(k) is None else abs(tf - exact(k)),
           "abs_error_2d_vs_jones": abs(tf2 - jones_transfer(k)),
           "setup": {"chord_m": C, "speed_mps": U, "air_density_kgm3": RHO, "elements": 16, "aspect_ratio": 1e4,
                     "pitch_amplitude_deg": 0.1, "pitch_axis": "quarter chord", "rk4_steps_per_period": 400,
                     "measured_element": "mid-span (7)"},
           "curve_2d": {"k": ks.tolist(), "implemented": [pair(z) for z in curve]},
           "wall_s": time.perf_counter() - t0}
    atomic_write_json(out / "result.json", res)
    _figure(out / "theodorsen.png", ks, curve, k, tf)
    print(f"k = {k:g}: implemented {tf.real:.5f} {tf.imag:+.5f}i, Jones {jones_transfer(k).real:.5f} "
          f"{jones_transfer(k).imag:+.5f}i, exact " + ("n/a" if exact(k) is None else
                                                      f"{exact(k).real:.5f} {exact(k).imag:+.5f}i"))
    return 0


def _figure(path: Path, ks, curve, k, tf) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from birdocp.bird.unsteady import jones_transfer

    kk = np.geomspace(0.01, 3.0, 300)
    J = np.array([jones_transfer(x) for x in kk])
    E = [exact(x) for x in kk]
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    cv = np.array(curve)
    for a, f, lab in ((ax[0], np.abs, "|C(k)|"), (ax[1], lambda z: np.degrees(np.angle(z)), "phase of C(k) (deg)")):
        if E[0] is not None:
            a.plot(kk, f(np.array(E)), "k-", lw=2, label="Theodorsen (exact)")
        a.plot(kk, f(J), "C1--", label="Jones approximation")
        a.plot(ks, f(cv), "C0o", ms=4, label="birdocp wagner, 2-D strip")
        a.plot([k], [f(np.array([tf]))[0]], "C3s", ms=8, label=f"birdocp, 16 elements, AR 1e4 (k = {k:g})")
        a.set_xscale("log")
        a.set_xlabel("reduced frequency k = omega c / (2U)")
        a.set_ylabel(lab)
        a.grid(True, alpha=0.3)
    ax[0].legend(fontsize=8)
    fig.suptitle("Circulatory lift / quasi-steady lift, pitch about the quarter chord")
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)


if __name__ == "__main__":
    sys.exit(main())
