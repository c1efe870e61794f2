"""Sparse factorisations of a symmetric positive definite matrix, chosen by name.

The registry :data:`FACTORIZATIONS` is the vocabulary of the scene key ``solver.backend``
(plus ``auto``: the fastest one installed, in the order of :data:`AUTO_ORDER`). SciPy's SuperLU
is always there; Intel MKL PARDISO through ``pypardiso`` where its wheels exist (x86_64);
SuiteSparse CHOLMOD through ``scikit-sparse`` where it builds (Debian: ``libsuitesparse-dev``;
it wants OpenBLAS, not the reference BLAS). A factorisation is kept across solves and reuses its
symbolic analysis (ordering, elimination tree) while the sparsity pattern is unchanged (the whole
run: the topology is fixed), so a new matrix costs only its numerical factorisation.

Each backend states ``refactor_cost``: what a numerical refactorisation plus the solves of a
bordered system's border (:mod:`cortex_ti.solve.constrained`, 14 columns) cost, in units of one
preconditioned GMRES iteration of the constrained solver (one back-substitution, one product
with the bordered matrix, the Gram-Schmidt: ~1.5-2 ms of CPU beyond the back-substitution at
2562 nodes inside a run, where the factor no longer sits in the cache); measured on the 2562-node
furrow's matrix (7686 unknowns, 162 k nonzeros) by ``benchmarks/solver_backends.py``
(docs/validation/speed.md). The constrained solver's rule for when to refactorise rather than
iterate weighs iterations against it (:class:`cortex_ti.solve.constrained.RefactorRule`); the
value shifts the balance, not the answer, which meets the GMRES tolerance either way.
"""

from __future__ import annotations

import ctypes
import functools
import glob
import os
import site
import sys

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError, thread_count

__all__ = [
    "FACTORIZATIONS",
    "AUTO_ORDER",
    "Factorization",
    "register_factorization",
    "choose_factorization",
    "backend_names",
    "same_pattern",
]

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
    unchanged, which is the case over a whole run unless it remeshes (then the analysis is redone
    once for the new mesh); they count their analyses in ``analyses``.
    """

    name = "base"
    #: numerical refactorisation + border solves, in preconditioned iterations (module docstring)
    refactor_cost = 20.0
    #: how to install it (for the message when it is asked for and missing)
    install = ""

    @staticmethod
    def available() -> bool:  # pragma: no cover - interface
        return True

    def factorize(self, a: sp.spmatrix) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def solve(self, b: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError


@register_factorization("superlu")
class SuperLUFactor(Factorization):
    """SciPy's SuperLU with a symmetric ordering (always available; no analysis reuse: SciPy
    does not expose it). Measured at 2562 nodes: factorisation 62-67 ms, a solve 1.1-1.7 ms,
    14 solves 10 ms: ~75 ms, 25 iterations of ~3 ms."""

    refactor_cost = 25.0

    def factorize(self, a):
        self._lu = spla.splu(
            a.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
        )

    def solve(self, b):
        return self._lu.solve(b)


@register_factorization("pardiso")
class PardisoFactor(Factorization):
    """Intel MKL PARDISO through ``pypardiso``, real SPD (mtype 2), upper triangle.

    Phase 11 (analysis, METIS ordering) runs only when the sparsity pattern changes;
    each new matrix costs only phase 22 (numerical factorisation). PARDISO's own iterative
    refinement in the solve phase is switched off (``iparm(8) = 0``): it tripled the cost of a
    back-substitution (1.6 ms instead of 0.6 ms at 2562 nodes) for a Cholesky solve that is
    backward stable already (residual 3e-14 without it), and the constrained solver refines
    against the unsquared system itself. MKL runs on ``CORTEX_TI_THREADS`` threads when that is
    set (``cortex-ti run --threads`` sets it), not on every core: on a shared machine its idle
    threads spinning against other jobs made a refactorisation 2x slower in CPU time.
    Measured at 2562 nodes (one thread): refactorisation 8-10 ms, one solve 0.6-0.7 ms,
    14 right-hand sides 2.9-3.5 ms. In a run a fresh factorisation and solve cost 35 ms of CPU
    and a reused solve 2.5-3 ms per iteration: ``refactor_cost`` 15.
    """

    refactor_cost = 15.0
    install = "pip install pypardiso (x86_64 only)"

    @staticmethod
    def available() -> bool:
        try:
            _pypardiso()
        except Exception:
            return False
        return True

    def __init__(self):
        self._solver = _pypardiso().PyPardisoSolver(mtype=2)
        threads = thread_count()  # checked: a bad CORTEX_TI_THREADS is one line, not a ValueError
        if threads is not None:  # the run's thread count (cortex_ti.runtime); MKL's default is every core
            self._solver.libmkl.MKL_Set_Num_Threads(ctypes.c_int(threads))
        self._pattern = None
        self._a = None
        self.analyses = 0  # symbolic analyses (phase 11) done

    def factorize(self, a):
        upper = sp.triu(a, format="csr")
        upper.sort_indices()
        dummy = np.zeros(upper.shape[0])
        if not same_pattern(self._pattern, upper):
            inside = embed_in_pattern(self._pattern, upper)
            if inside is not None:  # entries that are exactly zero now: the analysed pattern holds them
                upper = inside
            else:  # analyse the union, so that entries that come and go do not trigger it again
                if self._pattern is not None and self._pattern.shape != upper.shape:
                    self._solver.free_memory(everything=True)  # a new mesh: PARDISO starts afresh
                upper = pattern_union(self._pattern, upper)
                self.analyses += 1
                self._solver.set_phase(11)
                self._solver._call_pardiso(upper, dummy)
                self._solver.set_iparm(8, 0)  # after phase 11, which fills in the defaults (2 steps)
                self._pattern = upper
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


@register_factorization("cholmod")
class CholmodFactor(Factorization):
    """SuiteSparse CHOLMOD (supernodal) through ``scikit-sparse``: ``analyze`` once per sparsity
    pattern, ``cholesky_inplace`` for each new matrix. Measured at 2562 nodes with OpenBLAS:
    refactorisation 13-22 ms, one solve 0.6-0.7 ms, 14 right-hand sides 2.7-7.6 ms (with the
    reference BLAS the refactorisation took 55 ms). The fastest where MKL has no wheels
    (aarch64)."""

    refactor_cost = 15.0
    install = "pip install scikit-sparse (needs SuiteSparse: apt-get install libsuitesparse-dev)"

    @staticmethod
    def available() -> bool:
        try:
            import sksparse.cholmod  # noqa: F401
        except Exception:
            return False
        return True

    def __init__(self):
        self._factor = None
        self._pattern = None
        self.analyses = 0  # symbolic analyses done

    def factorize(self, a):
        from sksparse.cholmod import analyze

        a = a.tocsc()
        a.sort_indices()
        if self._factor is None or not same_pattern(self._pattern, a):
            # CSC of a symmetric matrix is the CSR of its transpose: the same keys, transposed
            inside = embed_in_pattern(None if self._pattern is None else self._pattern.T.tocsr(), a.T.tocsr())
            if inside is not None:
                a = inside.T.tocsc()
            else:
                a = pattern_union(None if self._pattern is None else self._pattern.T.tocsr(), a.T.tocsr()).T.tocsc()
                a.sort_indices()
                self.analyses += 1
                self._factor = analyze(a, mode="supernodal")
                self._pattern = a
        self._factor.cholesky_inplace(a)

    def solve(self, b):
        return self._factor(b)


def _pypardiso():
    """``pypardiso``, imported with MKL's runtime library named (:func:`_mkl_runtime`): its
    import already makes a solver (``pypardiso.scipy_aliases``), which would search for it."""
    path = _mkl_runtime()
    if path is not None:
        os.environ.setdefault("PYPARDISO_MKL_RT", path)
    import pypardiso

    return pypardiso


@functools.cache
def _mkl_runtime() -> str | None:
    """MKL's runtime library, found once per process where the ``mkl`` wheel puts it (the
    environment's ``lib``), for ``pypardiso`` (``PYPARDISO_MKL_RT``). Left to itself pypardiso
    looks for it in every new solver with ``ctypes.util.find_library`` and a recursive glob of
    the environment: 0.25 s of CPU and 1.7-2.5 s of wall time per solver (and once more at its
    import), measured on a loaded 2-core machine, against 0.3 ms with the path given. None: let
    pypardiso search."""
    if os.environ.get("PYPARDISO_MKL_RT"):
        return os.environ["PYPARDISO_MKL_RT"]
    for base in (sys.prefix, site.USER_BASE or ""):
        hits = [
            h
            for pat in ("lib/libmkl_rt.so*", "lib/libmkl_rt*.dylib", "Library/bin/mkl_rt*.dll")
            for h in glob.glob(os.path.join(base, pat))
        ]
        if hits:
            return min(hits, key=len)
    return None


def _keys(a: sp.csr_matrix) -> np.ndarray:
    """Row-major linear indices of the stored entries of a canonical CSR matrix (sorted)."""
    rows = np.repeat(np.arange(a.shape[0], dtype=np.int64), np.diff(a.indptr))
    return rows * a.shape[1] + a.indices


def embed_in_pattern(pattern: sp.csr_matrix | None, a: sp.csr_matrix) -> sp.csr_matrix | None:
    """``a`` stored on the (larger) sparsity pattern ``pattern``, explicit zeros where ``a`` has no
    entry; None if ``a`` has an entry outside it. SciPy's sparse products drop entries that come out
    exactly zero (a symmetric shape gives such zeros), so the pattern of the same mesh's matrix can
    shrink and grow by a few entries from one solve to the next: a factorisation keeps its symbolic
    analysis for any matrix that fits the analysed pattern.

    >>> p = sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 3.0]]))
    >>> embed_in_pattern(p, sp.csr_matrix(np.array([[4.0, 0.0], [0.0, 5.0]]))).nnz
    4
    >>> embed_in_pattern(sp.csr_matrix(np.eye(2)), p) is None
    True
    """
    if pattern is None or pattern.shape != a.shape:
        return None
    kp, ka = _keys(pattern), _keys(a)
    pos = np.searchsorted(kp, ka)
    if pos.size and (pos.max() >= kp.size or not np.array_equal(kp[pos], ka)):
        return None
    data = np.zeros(kp.size)
    data[pos] = a.data
    return sp.csr_matrix((data, pattern.indices.copy(), pattern.indptr.copy()), shape=a.shape)


def pattern_union(pattern: sp.csr_matrix | None, a: sp.csr_matrix) -> sp.csr_matrix:
    """``a`` stored on the union of its pattern and ``pattern`` (the same shape; else ``a``)."""
    if pattern is None or pattern.shape != a.shape:
        return a
    keys = np.union1d(_keys(pattern), _keys(a))
    n = a.shape[1]
    union = sp.csr_matrix((np.ones(keys.size), (keys // n, keys % n)), shape=a.shape)
    union.sort_indices()
    return embed_in_pattern(union, a)


def same_pattern(old: sp.spmatrix | None, new: sp.spmatrix) -> bool:
    """Whether two compressed sparse matrices (indices sorted) have the same sparsity pattern."""
    return (
        old is not None
        and old.shape == new.shape
        and np.array_equal(old.indptr, new.indptr)
        and np.array_equal(old.indices, new.indices)
    )


#: The order in which ``auto`` takes the installed backends (fastest first, docs/validation/speed.md)
AUTO_ORDER = ("pardiso", "cholmod", "superlu")


def choose_factorization(name: str = "auto") -> type:
    """The factorisation class for ``name``; ``auto`` takes the fastest installed."""
    if name == "auto":
        for candidate in AUTO_ORDER:
            if FACTORIZATIONS[candidate].available():
                return FACTORIZATIONS[candidate]
    if name not in FACTORIZATIONS:
        raise SolverError(f"unknown solver backend {name!r}; choose one of auto, {', '.join(FACTORIZATIONS)}")
    cls = FACTORIZATIONS[name]
    if not cls.available():
        here = [k for k, c in FACTORIZATIONS.items() if c.available()]
        raise SolverError(
            f"solver backend {name!r} is not installed here ({cls.install}); use auto or one of {', '.join(here)}"
        )
    return cls


def backend_names() -> list[str]:
    """The values ``solver.backend`` accepts: ``auto`` and every registered factorisation."""
    return ["auto", *FACTORIZATIONS]
