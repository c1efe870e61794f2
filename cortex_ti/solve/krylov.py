"""GMRES preconditioned on the right, stopped on the true residual.

Written here rather than taken from SciPy because :func:`scipy.sparse.linalg.gmres` preconditions
on the left: its inner loop stops when the *preconditioned* residual meets the tolerance, and only
then checks the true one. With the previous step's factorisation as preconditioner (the use in
:mod:`cortex_ti.solve.constrained`) the two differ by the conditioning of the bordered matrix:
measured on the 2562-node furrow, SciPy returned "not converged" after 5 iterations with a true
residual of 2e-10 to 1e-9 against a tolerance of 1e-10, so the caller refactorised on 9 of 12
steps. On the right, the residual GMRES minimises *is* ``b - A x``, so its stopping test is the
one the caller asks for. (``scipy.sparse.linalg.gcrotmk`` also preconditions on the right and
converged, but restarts through Python-level recycling machinery at 1.0-1.3x the time.)

Arnoldi with modified Gram-Schmidt, Givens rotations for the small least-squares problem; no
restart (the caller gives up and refactorises past ``maxiter``).

:func:`gmres_left` is SciPy's left-preconditioned GMRES (the same iterates and stopping tests, for a
caller whose residual rows have unrelated scales, so that the test must be on the preconditioned
residual: the fluids' coupled solve) with one product per iteration and no other: SciPy's
``LinearOperator`` applies the operator once to guess its dtype, and its GMRES applies it again
after every cycle for the true residual, which the caller wants as well. Here the products ``A v_j``
of the Arnoldi vectors are kept, so the true residual ``r0 - sum_j y_j A v_j`` costs no product
(docs/validation/fluids.md: at 10242 nodes a product is 1.3 CPU s and a solve took 7.6 iterations and
four more products, the initial residual's and three of these).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["gmres_left", "gmres_right"]


def gmres_right(
    matvec: Callable[[np.ndarray], np.ndarray],
    psolve: Callable[[np.ndarray], np.ndarray],
    b: np.ndarray,
    x0: np.ndarray,
    rtol: float,
    maxiter: int,
) -> tuple[np.ndarray, int, bool]:
    """Solve ``A x = b`` by GMRES on ``A P^{-1} (P x) = b`` from ``x0``.

    Returns ``(x, iterations, converged)``, converged meaning ``|b - A x| <= rtol |b|`` (the
    residual GMRES minimises; up to the rounding of the recurrence, which the caller measures).

    >>> import numpy as np
    >>> a = np.array([[4.0, 1.0], [1.0, 3.0]])
    >>> x, it, ok = gmres_right(lambda v: a @ v, lambda v: v / np.diag(a), np.array([1.0, 2.0]),
    ...                         np.zeros(2), 1e-12, 10)
    >>> ok, it, bool(np.allclose(a @ x, [1.0, 2.0], atol=1e-12))
    (True, 2, True)
    """
    bnorm = float(np.linalg.norm(b))
    tol = rtol * bnorm
    r = b - matvec(x0)
    beta = float(np.linalg.norm(r))
    if beta <= tol:
        return x0, 0, True
    n = b.size
    v = np.empty((maxiter + 1, n))
    z = np.empty((maxiter, n))
    h = np.zeros((maxiter + 1, maxiter))
    g = np.zeros(maxiter + 1)
    cs = np.zeros(maxiter)
    sn = np.zeros(maxiter)
    v[0] = r / beta
    g[0] = beta
    k = 0
    for j in range(maxiter):
        z[j] = psolve(v[j])
        w = matvec(z[j])
        for i in range(j + 1):  # modified Gram-Schmidt
            h[i, j] = v[i] @ w
            w -= h[i, j] * v[i]
        h[j + 1, j] = np.linalg.norm(w)
        if h[j + 1, j] > 0.0:
            v[j + 1] = w / h[j + 1, j]
        for i in range(j):  # earlier rotations on the new column
            t = cs[i] * h[i, j] + sn[i] * h[i + 1, j]
            h[i + 1, j] = -sn[i] * h[i, j] + cs[i] * h[i + 1, j]
            h[i, j] = t
        d = np.hypot(h[j, j], h[j + 1, j])
        if d == 0.0:  # breakdown with nothing gained: stop, not converged
            break
        cs[j], sn[j] = h[j, j] / d, h[j + 1, j] / d
        h[j, j], h[j + 1, j] = d, 0.0
        g[j + 1] = -sn[j] * g[j]
        g[j] = cs[j] * g[j]
        k = j + 1
        if abs(g[k]) <= tol:
            break
    y = np.linalg.solve(np.triu(h[:k, :k]), g[:k])
    return x0 + z[:k].T @ y, k, bool(abs(g[k]) <= tol)


def gmres_left(
    matvec: Callable[[np.ndarray], np.ndarray],
    psolve: Callable[[np.ndarray], np.ndarray],
    b: np.ndarray,
    x0: np.ndarray | None,
    rtol: float,
    maxiter: int,
    restart: int = 200,
) -> tuple[np.ndarray, np.ndarray, int, bool]:
    """Solve ``A x = b`` by GMRES on ``P^{-1} A x = P^{-1} b`` from ``x0`` (None: zero), as
    :func:`scipy.sparse.linalg.gmres` with ``M = P^{-1}``, ``atol = 0`` (module docstring).

    A cycle stops when the preconditioned residual's estimate is at most ``rtol |P^{-1} b|``; then the
    true residual must be at most ``rtol |b|``, else another cycle starts with SciPy's tighter inner
    tolerance. Returns ``(x, r, iterations, converged)``, ``r = b - A x`` from the kept products (one
    product per iteration and one for ``x0``'s residual, none after).

    >>> import numpy as np
    >>> a = np.array([[4.0, 1.0], [1.0, 3.0]])
    >>> x, r, it, ok = gmres_left(lambda v: a @ v, lambda v: v / np.diag(a), np.array([1.0, 2.0]),
    ...                           None, 1e-12, 10)
    >>> ok, it, bool(np.allclose(a @ x, [1.0, 2.0], atol=1e-12)), bool(np.allclose(r, [1.0, 2.0] - a @ x))
    (True, 2, True, True)
    """
    eps = np.finfo(float).eps
    bnorm = float(np.linalg.norm(b))
    x = np.zeros_like(b) if x0 is None else np.array(x0, float)
    if bnorm == 0.0:
        return np.zeros_like(b), np.zeros_like(b), 0, True
    atol = rtol * bnorm
    r = b - matvec(x) if x.any() else b.copy()
    rnorm = float(np.linalg.norm(r))
    if rnorm < atol:
        return x, r, 0, True
    ptol_factor = 1.0
    ptol = float(np.linalg.norm(psolve(b))) * min(ptol_factor, atol / bnorm)
    total = 0
    while total < maxiter:
        m = min(restart, maxiter - total)
        v = np.empty((m + 1, b.size))
        av = np.empty((m, b.size))
        h = np.zeros((m + 1, m))
        g = np.zeros(m + 1)
        cs, sn = np.zeros(m), np.zeros(m)
        v[0] = psolve(r)
        g[0] = np.linalg.norm(v[0])
        v[0] /= g[0]
        k, breakdown, presid = 0, False, 0.0
        for j in range(m):
            av[j] = matvec(v[j])
            w = psolve(av[j])
            h0 = np.linalg.norm(w)
            for i in range(j + 1):  # modified Gram-Schmidt
                h[i, j] = v[i] @ w
                w -= h[i, j] * v[i]
            h[j + 1, j] = np.linalg.norm(w)
            v[j + 1] = w
            if h[j + 1, j] <= eps * h0:  # the exact solution is in the space
                h[j + 1, j], breakdown = 0.0, True
            else:
                v[j + 1] /= h[j + 1, j]
            for i in range(j):  # earlier rotations on the new column
                t = cs[i] * h[i, j] + sn[i] * h[i + 1, j]
                h[i + 1, j] = -sn[i] * h[i, j] + cs[i] * h[i + 1, j]
                h[i, j] = t
            d = np.hypot(h[j, j], h[j + 1, j])
            cs[j], sn[j] = (h[j, j] / d, h[j + 1, j] / d) if d > 0.0 else (1.0, 0.0)
            h[j, j], h[j + 1, j] = d, 0.0
            g[j + 1] = -sn[j] * g[j]
            g[j] = cs[j] * g[j]
            k, presid = j + 1, abs(g[j + 1])
            if presid <= ptol or breakdown:
                break
        total += k
        diag = np.diag(h[:k, :k]).copy()
        y = np.linalg.solve(np.triu(h[:k, :k]) + np.diag(np.where(diag == 0.0, 1.0, 0.0)), g[:k] * (diag != 0.0))
        x = x + y @ v[:k]
        r = r - y @ av[:k]
        rnorm = float(np.linalg.norm(r))
        if rnorm <= atol or breakdown:
            break
        ptol_factor = max(eps, 0.25 * ptol_factor) if presid <= ptol else min(1.0, 1.5 * ptol_factor)
        ptol = presid * min(ptol_factor, atol / rnorm)
    return x, r, total, rnorm <= atol
