"""Sparse factorisations of a symmetric positive definite matrix, chosen by name.

The registry :data:`FACTORIZATIONS` is the vocabulary of the scene key ``solver.backend``
(plus ``auto``: the fastest one installed). SciPy's SuperLU is always there; Intel MKL PARDISO
through ``pypardiso`` where its wheels exist (x86_64). A factorisation is kept across solves and
reuses its symbolic analysis while the sparsity pattern is unchanged (the whole run: the
topology is fixed).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError

__all__ = ["FACTORIZATIONS", "Factorization", "register_factorization", "choose_factorization", "backend_names"]

FACTORIZATIONS: dict[str, type] = {}


def register_factorization(name: str):
    def deco(cls):
        cls.name = name
        FACTORIZATIONS[name] = cls
        return cls

    return deco


class Factorization:
    """A sparse SPD factorisation kept across solves.

    ``factorize(a)`` factors a new matrix; backends that can reuse the symbolic
    analysis (ordering, elimination tree) do so while the sparsity pattern is
    unchanged, which is the case over a whole run because the topology is fixed.
    """

    name = "base"

    @staticmethod
    def available() -> bool:  # pragma: no cover - interface
        return True

    def factorize(self, a: sp.spmatrix) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def solve(self, b: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError


@register_factorization("superlu")
class SuperLUFactor(Factorization):
    """SciPy's SuperLU with a symmetric ordering (always available; no analysis reuse)."""

    def factorize(self, a):
        self._lu = spla.splu(a.tocsc(), permc_spec="MMD_AT_PLUS_A",
                             diag_pivot_thresh=0.0, options={"SymmetricMode": True})

    def solve(self, b):
        return self._lu.solve(b)


@register_factorization("pardiso")
class PardisoFactor(Factorization):
    """Intel MKL PARDISO through ``pypardiso``, real SPD (mtype 2), upper triangle.

    Phase 11 (analysis, METIS ordering) runs only when the sparsity pattern changes;
    each new matrix costs only phase 22 (numerical factorisation).
    """

    @staticmethod
    def available() -> bool:
        try:
            import pypardiso  # noqa: F401
        except Exception:
            return False
        return True

    def __init__(self):
        import pypardiso

        self._solver = pypardiso.PyPardisoSolver(mtype=2)
        self._pattern = None
        self._a = None

    def factorize(self, a):
        upper = sp.triu(a, format="csr")
        upper.sort_indices()
        pattern = (upper.shape, upper.indptr.copy(), upper.indices.copy())
        same = (self._pattern is not None and self._pattern[0] == pattern[0]
                and np.array_equal(self._pattern[1], pattern[1]) and np.array_equal(self._pattern[2], pattern[2]))
        dummy = np.zeros(upper.shape[0])
        if not same:
            self._solver.set_phase(11)
            self._solver._call_pardiso(upper, dummy)
            self._pattern = pattern
        self._solver.set_phase(22)
        self._solver._call_pardiso(upper, dummy)
        self._a = upper

    def solve(self, b):
        self._solver.set_phase(33)
        out = self._solver._call_pardiso(self._a, np.asfortranarray(b))
        return out.reshape(b.shape)

    def __del__(self):
        try:
            self._solver.free_memory(everything=True)
        except Exception:
            pass


def choose_factorization(name: str = "auto") -> type:
    """The factorisation class for ``name``; ``auto`` takes the fastest installed."""
    if name == "auto":
        for candidate in ("pardiso", "superlu"):
            if FACTORIZATIONS[candidate].available():
                return FACTORIZATIONS[candidate]
    if name not in FACTORIZATIONS:
        raise SolverError(f"unknown solver backend {name!r}; choose one of auto, {', '.join(FACTORIZATIONS)}")
    cls = FACTORIZATIONS[name]
    if not cls.available():
        raise SolverError(f"solver backend {name!r} is not installed here")
    return cls




def backend_names() -> list[str]:
    """The values ``solver.backend`` accepts: ``auto`` and every registered factorisation."""
    return ["auto", *FACTORIZATIONS]
