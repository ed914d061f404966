"""Second derivatives for IPOPT's exact-Hessian mode from the engine's oracle: forward differences of
an exact Jacobian (StencilHessian, the perturbed points in a thread pool) and a fixed second-derivative
tensor (FixedHessian), on a small NLP whose Hessian is known in closed form."""

import casadi as ca
import numpy as np
import pytest

from birdocp.engine.oracle import ConstraintOracle, Evaluator, FixedHessian, StencilHessian


class Toy(Evaluator):
    """G(z) = [objective; two constraints] with analytic first and second derivatives."""

    nz, ng = 3, 3
    jac_sparsity = ca.Sparsity.dense(3, 3)

    def __init__(self, blocked=None):
        self.blocked = blocked  # a point where J is NaN (no evaluation there)

    def evaluate(self, z):
        x, y, w = z
        g = np.array([x ** 2 + y ** 2 + w ** 2, np.sin(x) * y + w, x * y * w])
        J = np.array([[2 * x, 2 * y, 2 * w], [np.cos(x) * y, np.sin(x), 1.0], [y * w, x * w, x * y]])
        if self.blocked is not None and np.array_equal(z, self.blocked):
            J = np.full_like(J, np.nan)
        return g, J

    def jacobian_near(self, zk, z):
        return self.jacobian(zk)

    @staticmethod
    def hessians(z):
        """[i] = d^2 G_i / dz^2 (analytic)."""
        x, y, w = z
        return np.array([2 * np.eye(3),
                         [[-np.sin(x) * y, np.cos(x), 0], [np.cos(x), 0, 0], [0, 0, 0]],
                         [[0, w, y], [w, 0, x], [y, x, 0]]], float)


Z = np.array([0.7, -0.4, 1.3])


def test_stencil_columns_are_the_second_derivatives_and_thread_independent():
    ev = Toy()
    one, two = StencilHessian(1e-6, threads=1), StencilHessian(1e-6, threads=2)
    c1, c2 = one.columns(ev, Z), two.columns(ev, Z)
    assert np.array_equal(c1, c2)                             # the thread pool changes nothing, to the bit
    H = Toy.hessians(Z)                                       # c[k, i, j] = d^2 G_i / dz_j dz_k
    assert np.allclose(c1, np.transpose(H, (2, 0, 1)), rtol=0, atol=5e-6)
    assert two.last[1] is c2 and np.array_equal(two.last[0], Z)


def test_stencil_falls_back_to_a_backward_difference():
    zf = Z.copy()
    zf[1] += 1e-6
    c = StencilHessian(1e-6, threads=2).columns(Toy(blocked=zf), Z)
    assert np.all(np.isfinite(c))
    assert np.allclose(c[1], Toy.hessians(Z)[:, :, 1], atol=5e-6)


@pytest.mark.parametrize("hessian", ["stencil", "fixed"])
def test_ipopt_with_the_oracles_second_derivatives(hessian):
    """min |z|^2 s.t. sin(x) y + w = 0.5, x y w >= 0.2: the same optimum as IPOPT on the symbolic NLP
    (exact Hessian); with the stencil in as few iterations, and converging with fixed second
    derivatives from a nearby point too."""
    zs = ca.MX.sym("z", 3)
    sym = ca.vertcat(ca.sumsqr(zs), ca.sin(zs[0]) * zs[1] + zs[2], zs[0] * zs[1] * zs[2])
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-10}
    bounds = {"x0": [1.0, 1.0, 1.0], "lbg": [0.5, 0.2], "ubg": [0.5, np.inf]}
    ref = ca.nlpsol("ref", "ipopt", {"x": zs, "f": sym[0], "g": sym[1:]}, opts)
    zref = np.asarray(ref(**bounds)["x"]).ravel()
    ev = Toy()
    fd = StencilHessian(1e-6, threads=2) if hessian == "stencil" else FixedHessian(
        np.transpose(Toy.hessians(zref + 0.05), (2, 0, 1)))
    oracle = ConstraintOracle(ev, "toy", fd_hessian=fd)
    G = oracle(zs)
    solver = ca.nlpsol("toy", "ipopt", {"x": zs, "f": G[0], "g": G[1:]},
                       opts | {"ipopt.hessian_approximation": "exact"})
    z = np.asarray(solver(**bounds)["x"]).ravel()
    assert solver.stats()["success"]
    assert np.allclose(z, zref, atol=1e-7)
    if hessian == "stencil":
        assert solver.stats()["iter_count"] <= ref.stats()["iter_count"] + 1
