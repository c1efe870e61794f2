"""The stiffness of the shape dynamics: the normal modes of the linearised normal velocity."""

from __future__ import annotations

import numpy as np

__all__ = ["stiffest_normal_mode"]


def stiffest_normal_mode(evaluate, points: np.ndarray, iterations: int = 30, eps: float = 1e-7,
                         seed: int = 0) -> tuple[float, np.ndarray]:
    """The most strongly growing or decaying normal mode of the shape dynamics at ``points``.

    The shape moves by ``dX/dt = v_n(X) n``; a normal perturbation ``s`` (one number per node)
    evolves with the Jacobian ``J s = d v_n / dX [s n]``. Power iteration with finite
    differences (``iterations`` + 1 solves) returns ``(lambda, s)``: the eigenvalue of largest
    magnitude and its unit mode. ``lambda < 0``: explicit Euler is stable for
    ``dt < 2 / |lambda|``; ``lambda > 0``: the discrete problem has a growing mode that no time
    step removes (for instance spurious normal modes the bending viscosity cannot hold down).
    """
    ev0 = evaluate(points)
    n, vn0 = ev0.normal, ev0.normal_speed
    s = np.random.default_rng(seed).standard_normal(len(points))
    s /= np.linalg.norm(s)
    lam = 0.0
    for _ in range(iterations):
        js = (evaluate(points + eps * s[:, None] * n).normal_speed - vn0) / eps
        lam = float(s @ js)
        s = js / np.linalg.norm(js)
    return lam, s
