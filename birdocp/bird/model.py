"""The bird model as CasADi Functions, built once per structural configuration.

Split (the data/right-hand-side split of ``docs/model.md``): everything that depends only on time and parameters (wing geometry,
kinematic velocity, lifting-line matrices) is the per-time data ``d = data(t, p)``; the state right-hand
side ``rhs(x, d, p)`` is small. ``f(x, t, p) = rhs(x, data(t, p), p)`` is offered for users and tests.

State x = (u [m/s] forward along x', w [m/s] down along z', q [rad/s] pitch rate nose-up, theta [rad]
pitch angle). Body frame: x' forward, z' down; loads ``Fx_N``, ``Fz_N`` and ``My_Nm`` (nose-up
positive) about the centre of mass G. Parameters ``p``: :data:`birdocp.bird.config.PARAM_NAMES`.
"""
from __future__ import annotations

import functools
import time

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, param_vector
# the model's pieces live in layout (state, data, structure), loads (load expressions) and graphs
# (the SX Functions); their names stay importable from here
from birdocp.bird.graphs import GEOMETRY_OUTPUTS, SECTION_OUTPUTS, WING_POWER_NAMES, aero_blocks, build as _build  # noqa: F401
from birdocp.bird.layout import (DATA_BLOCKS, DATA_OFFSETS, N_DATA, N_EL, N_MASS, STATE_NAMES,  # noqa: F401
                                 Structure, air_state, unpack_data, unpack_mass)
from birdocp.bird.loads import load_terms, section_terms, unsteady_data_offset  # noqa: F401
from birdocp.engine.cache import register_cache
from birdocp.engine.lazy import LazyFunction
from birdocp.engine.ode import ODE

GRAPH_FUNCTIONS = ("pre", "post", "rhs", "data", "geometry", "loads_d", "detail_d", "rhs_wind",
                   "loads_wind")
"""The SX Functions of a :class:`BirdModel` that the graph cache stores (the MX compositions ``f``,
``loads``, ``aero_detail`` are rebuilt from them in milliseconds)."""

OPTIONAL_FUNCTIONS = ("mass_points", "wing_power_d", "section_d", "aero_guess_d", "held_d")
"""Functions only some structures have (wing masses; unsteady or stall sections); None otherwise."""

_EAGER = ("pre", "post", "rhs")  # what every solve needs; the rest is read from the cache on first use
_LAZY = ("pre",)  # of those, read only when evaluated (LazyFunction): its stage-grid values are on disk


def graph_key(structure: Structure) -> dict:
    """Everything that changes the model's graphs: the source of :mod:`birdocp.bird` and
    :mod:`birdocp.engine` (hashed), the :class:`Structure` (frequency, circulation, relaxed
    evaluations, kinematic velocity, its backward step, tail on/off, wing masses on/off; every other
    configuration value
    is a number in ``p``), the parameter layout and the birdocp version (CasADi's version and the
    cache format are added by :mod:`birdocp.engine.graphcache`).

    Parameters
    ----------
    structure : Structure
        Structure of the model.

    Returns
    -------
    dict
    """
    from pathlib import Path

    from birdocp import __version__
    from birdocp.engine import graphcache

    here = Path(__file__).resolve().parent
    sources = list(here.rglob("*.py")) + list((here.parent / "engine").rglob("*.py"))
    return {"model": "bird", "sources_sha256": graphcache.source_digest(sources),
            "structure": {k: getattr(structure, k) for k in structure.__dataclass_fields__},
            "param_names": list(PARAM_NAMES), "n_data": N_DATA, "birdocp": __version__}


class BirdModel:
    """CasADi Functions of the bird for one :class:`Structure`; numbers go in ``p``.

    Functions (built once, or read from the graph cache :mod:`birdocp.engine.graphcache` keyed by
    :func:`graph_key`; Functions other than ``pre``, ``post``, ``rhs`` are read on first use):

    * ``geometry(t, p)``: named outputs :data:`GEOMETRY_OUTPUTS` (merged line 3x33 in the code frame
      with origin on the body centre line at the shoulders, chords, directions, diagnostics);
    * ``data(t, p) -> d`` (:data:`N_DATA` values, layout :data:`DATA_BLOCKS`);
    * ``pre(t, p)`` (the wing in the arm frame) and ``post(local, t, p) -> d``, with
      ``data = post(pre(t, p), t, p)``; ``pre`` depends on the parameters ``pre_params`` only;
    * ``rhs(x, d, p) -> xdot`` and ``loads_d(x, d, p) -> [Fx_N, Fz_N, My_Nm]``;
    * ``rhs_wind(x, d, p, wind_mps, wind_rate_mps2)`` and ``loads_wind``: the same with a uniform wind
      (inertial frame, X forward, Z down, m/s) in the air velocity of every wing element and of the
      tail (:func:`air_state`); ``wind_rate_mps2`` its rate along the trajectory [m/s^2], which with
      ``aero.unsteady = "wagner"`` makes the added mass react to the air-relative acceleration
      (:func:`birdocp.bird.layout.air_wind_rate`, frame rotation included; unused otherwise); with a
      zero wind and rate they equal ``rhs`` and ``loads_d`` exactly;
    * ``f(x, t, p) -> xdot``, ``loads(x, t, p)`` and ``aero_detail(x, t, p)`` (circulations, angles of
      attack) composed in MX;
    * with wing masses, ``mass_points(t, p)`` and ``wing_power_d(x, d, p)`` (else None).

    ``ode`` (the :class:`~birdocp.engine.ode.ODE` the engine solves) has the data as the
    MX composition of ``pre`` and ``post`` (the same numbers as ``data``).

    ``graph_source`` says where the graphs came from: ``"built"``, ``"cache"`` (read) or
    ``"built+stored"``; ``graph_s`` the seconds it took. Most users call :func:`get_model`, which
    shares one model per structure.

    Parameters
    ----------
    structure : Structure
        What changes the graphs (not the numbers): the frequency, circulation and kinematic-velocity variants,
        tail, drag and wing-mass switches (``Structure.of(cfg)``).
    use_cache : bool
        Read and store the graphs in the on-disk graph cache (when it is enabled).
    """

    def __init__(self, structure: Structure, use_cache: bool = True):
        from birdocp.engine import graphcache

        self.structure = structure
        t0 = time.perf_counter()
        self._entry = None
        self._fns: dict = {}
        use_cache = use_cache and graphcache.enabled()
        key = graph_key(structure) if use_cache else None
        if use_cache:
            entry = graphcache.load("bird-model", key)
            if entry is not None and set(GRAPH_FUNCTIONS) <= set(entry.names):
                try:
                    for name in _EAGER:
                        sig = entry.signature(name) if name in _LAZY else None
                        # pre (0.25 s to read) only when it is evaluated: its stage-grid values are
                        # usually on disk (engine.datastore)
                        self._fns[name] = (LazyFunction(functools.partial(self._read, name), sig) if sig
                                           else entry.function(name))
                    self.pre_params = tuple(int(i) for i in entry.meta["pre_params"])
                    self._entry = entry
                except (graphcache.CacheMiss, KeyError, TypeError, ValueError):
                    self._fns = {}
                    entry.discard()
            elif entry is not None:  # written without every Function: replace it
                entry.discard()
        if self._entry is None:
            self._fns, self.pre_params = _build(structure)
            self.graph_source = "built"
            if use_cache and graphcache.store("bird-model", key, {k: f for k, f in self._fns.items() if f is not None},
                                              {"pre_params": list(self.pre_params)}) is not None:
                self.graph_source = "built+stored"
        else:
            self.graph_source = "cache"
        self.period_s = 1.0 / structure.frequency_hz
        data_sig = {"name": "data", "size_in": [[1, 1], [len(PARAM_NAMES), 1]],
                    "size_out": [list(self.post.size_out(0))]}
        data_mx = LazyFunction(self._compose_data, data_sig) if isinstance(self.pre, LazyFunction) \
            else self._compose_data()
        self.ode = ODE(rhs=self.rhs, data=data_mx, forcing_period=self.period_s,
                               state_names=structure.state_names, param_names=PARAM_NAMES,
                               pre=self.pre, post=self.post, pre_params=self.pre_params,
                               graph_key=graphcache.key_digest(key) if use_cache else "")
        self.graph_s = time.perf_counter() - t0

    def _compose_data(self) -> ca.Function:
        # data(t, p) = post(pre(t, p), t, p), composed in MX (the same numbers as the full data graph)
        tm, pm = ca.MX.sym("t"), ca.MX.sym("p", len(PARAM_NAMES))
        return ca.Function("data", [tm, pm], [self.post(self.pre(tm, pm), tm, pm)], ["t", "p"], ["d"])

    def _read(self, name: str) -> ca.Function:
        """``name`` from the cache entry, rebuilt (and re-stored) if the entry broke since it was opened."""
        from birdocp.engine import graphcache

        try:
            return self._entry.function(name)
        except graphcache.CacheMiss:
            built, _ = _build(self.structure)
            graphcache.store("bird-model", graph_key(self.structure), {k: v for k, v in built.items() if v is not None},
                             {"pre_params": list(self.pre_params)})
            return built[name]

    def _function(self, name: str) -> ca.Function | None:
        if name in self._fns:
            return self._fns[name]
        if name in OPTIONAL_FUNCTIONS and self._entry is not None and name not in self._entry.names:
            self._fns[name] = None  # this structure has none
            return None
        from birdocp.engine import graphcache
        try:
            f = self._entry.function(name)
        except graphcache.CacheMiss:  # broken after the manifest check: rebuild (and re-store)
            built, _ = _build(self.structure)
            graphcache.store("bird-model", graph_key(self.structure),
                             {k: v for k, v in built.items() if v is not None},
                             {"pre_params": list(self.pre_params)})
            self._fns.update((k, v) for k, v in built.items() if k not in self._fns)
            f = self._fns[name]
        self._fns[name] = f
        return f

    def __getattr__(self, name):
        if name in GRAPH_FUNCTIONS or name in OPTIONAL_FUNCTIONS:
            return self._function(name)
        if name in ("f", "loads", "aero_detail"):
            xm, tm, pm = ca.MX.sym("x", self.ode.nx), ca.MX.sym("t"), ca.MX.sym("p", len(PARAM_NAMES))
            dm = self._function("data")(tm, pm)
            if name == "f":
                f = ca.Function("f", [xm, tm, pm], [self.rhs(xm, dm, pm)], ["x", "t", "p"], ["xdot"])
            elif name == "loads":
                f = ca.Function("loads", [xm, tm, pm], [self.loads_d(xm, dm, pm)], ["x", "t", "p"], ["loads"])
            else:
                f = ca.Function("aero_detail", [xm, tm, pm], self.detail_d(xm, dm, pm),
                                ["x", "t", "p"], ["gamma", "alpha_rad", "vp_mps", "F_code"])
            self.__dict__[name] = f
            return f
        raise AttributeError(name)

    def wing_power_history(self, t, X, p) -> dict:
        """The wing powers :data:`WING_POWER_NAMES` along a trajectory (numbers).

        t: times [s] (K); X: states (K x 4); p: parameter vector. Returns a dict of arrays (K), all
        zeros for a model without wing masses (massless wings do no inertial work)."""
        t = np.asarray(t, float).ravel()
        X = np.asarray(X, float).reshape(len(t), -1)
        if self.wing_power_d is None:
            return {k: np.zeros(len(t)) for k in WING_POWER_NAMES}
        pd = ca.DM(np.asarray(p, float))
        K = len(t)
        D = self.data.map(K)(ca.DM(t).T, ca.repmat(pd, 1, K))
        P = np.asarray(self.wing_power_d.map(K)(ca.DM(X.T), D, ca.repmat(pd, 1, K)))
        return {k: P[i].copy() for i, k in enumerate(WING_POWER_NAMES)}

    def complete_state(self, x, p, t_s: float = 0.0) -> np.ndarray:
        """The full state (u, w, q, theta, aerodynamic states) from a body state x (4 numbers) at time
        ``t_s``: the lag and separation states on the quasi-steady manifold (``aero_guess_d``). A full
        state is returned as it is."""
        x = np.asarray(x, float).ravel()
        nx = self.ode.nx
        if x.size == nx or x.size != 4:
            return x
        pd = ca.DM(np.asarray(p, float))
        z = np.asarray(self.aero_guess_d(ca.DM(x), self.data(float(t_s), pd), pd)).ravel()
        return np.concatenate([x, z])

    def evaluate(self, state, t, p) -> dict:
        """Body-frame loads and the state derivative at one (state, t) for parameters p."""
        x = ca.DM(self.complete_state(state, p, t))
        d = self.data(float(t), ca.DM(np.asarray(p, float)))
        loads = np.array(self.loads_d(x, d, p)).ravel()
        xdot = np.array(self.rhs(x, d, p)).ravel()
        return {"Fx_N": float(loads[0]), "Fz_N": float(loads[1]), "My_Nm": float(loads[2]),
                "xdot": xdot.tolist()}


@functools.lru_cache(maxsize=8)
def _model_for(structure: Structure) -> BirdModel:
    return BirdModel(structure)


register_cache("bird.models", _model_for)


def _from_model(name: str) -> property:
    """A read-only property of :class:`ConfiguredModel`: the shared model's attribute ``name``."""
    return property(lambda self: getattr(self.model, name),
                    doc=f"The shared model's ``{name}`` (see :class:`BirdModel`).")


class ConfiguredModel:
    """A (shared, cached) :class:`BirdModel` together with one configuration's parameter vector
    ``p0``. The model's attributes that callers use are read-only properties here (listed below,
    nothing else falls through: anything more is ``.model.<name>``)."""

    def __init__(self, model: BirdModel, cfg: Config):
        self.model = model
        self.cfg = cfg
        self.p0 = param_vector(cfg)

    def evaluate(self, state, t, p=None) -> dict:
        """:meth:`BirdModel.evaluate` at this configuration's parameters (or ``p``)."""
        return self.model.evaluate(state, t, self.p0 if p is None else p)

    def complete_state(self, x, p, t_s: float = 0.0) -> np.ndarray:
        """:meth:`BirdModel.complete_state`."""
        return self.model.complete_state(x, p, t_s)

    def wing_power_history(self, t, X, p) -> dict:
        """:meth:`BirdModel.wing_power_history`."""
        return self.model.wing_power_history(t, X, p)

    # what the model is and where its graphs came from
    structure = _from_model("structure")
    pre_params = _from_model("pre_params")
    graph_source = _from_model("graph_source")
    period_s = _from_model("period_s")
    ode = _from_model("ode")
    # its Functions (GRAPH_FUNCTIONS, OPTIONAL_FUNCTIONS, and the MX compositions f, loads, aero_detail)
    pre = _from_model("pre")
    post = _from_model("post")
    rhs = _from_model("rhs")
    data = _from_model("data")
    geometry = _from_model("geometry")
    loads_d = _from_model("loads_d")
    detail_d = _from_model("detail_d")
    rhs_wind = _from_model("rhs_wind")
    loads_wind = _from_model("loads_wind")
    mass_points = _from_model("mass_points")
    wing_power_d = _from_model("wing_power_d")
    section_d = _from_model("section_d")
    aero_guess_d = _from_model("aero_guess_d")
    held_d = _from_model("held_d")
    f = _from_model("f")
    loads = _from_model("loads")
    aero_detail = _from_model("aero_detail")


def get_model(cfg: Config) -> ConfiguredModel:
    """The model for ``cfg``: graphs cached per :class:`Structure`, numbers from ``cfg`` in ``p0``.

    Parameters
    ----------
    cfg : Config
        The configuration.

    Returns
    -------
    ConfiguredModel
        The shared :class:`BirdModel` (``.model``) with this configuration's parameter vector.
    """
    return ConfiguredModel(_model_for(Structure.of(cfg)), cfg)


__all__ = ["BirdModel", "get_model", "air_state", "load_terms", "param_vector", "STATE_NAMES", "DATA_BLOCKS", "N_DATA",
           "unpack_data", "GEOMETRY_OUTPUTS", "Structure", "N_MASS", "unpack_mass", "WING_POWER_NAMES",
           "GRAPH_FUNCTIONS", "OPTIONAL_FUNCTIONS", "graph_key"]
