"""Host speed of HTM vs DQ forward kinematics (pure Python, numpy, numpy batch, numba).

Each (implementation, algebra) is timed in blocks of ``calls`` FKs; blocks of the two algebras
alternate (ABBA order) so that a drift of the machine affects both; per-FK time = block time /
FKs in the block, measured on the thread's CPU clock (``time.thread_time_ns``: time spent waiting
for a core is not counted, so machine load does not move it); nothing is printed inside a block.
"""

from __future__ import annotations

import time

import numpy as np

from pipeline.studies.mariano2019 import algebra as A

IMPLS = ("python", "numpy", "numpy_batch", "numba")
ALGEBRAS = ("htm", "dq")


def _python_fn(chain, algebra):
    if algebra == "htm":
        return lambda q: A.htm_translation(A.fk_htm_chain(chain, q))
    return lambda q: A.dq_translation(A.fk_dq_chain(chain, q))


def _block(impl: str, algebra: str, chain, Q: np.ndarray, calls: int):
    """Return a zero-argument function running ``calls`` FKs (or one batch) and the FK count."""
    from pipeline.kinematics import fk_dq, fk_htm

    if impl == "python":
        fn = _python_fn(chain, algebra)
        qs = [list(map(float, q)) for q in Q[:calls]]

        def run():
            for q in qs:
                fn(q)
        return run, len(qs)
    if impl == "numpy":
        fn = fk_htm if algebra == "htm" else fk_dq
        qs = list(Q[:calls])

        def run():
            for q in qs:
                fn(chain, q)
        return run, len(qs)
    if impl == "numpy_batch":
        fn = fk_htm if algebra == "htm" else fk_dq
        return (lambda: fn(chain, Q)), Q.shape[0]
    if impl == "numba":
        from pipeline.solvers.kernels import kin as _kin

        kern = _kin.fk_htm_batch if algebra == "htm" else _kin.fk_dq_batch
        out = np.empty((Q.shape[0], 3))
        args = (np.asarray(chain.a), np.asarray(chain.alpha), np.asarray(chain.d), np.asarray(chain.theta_offset),
                np.asarray(chain.prismatic), chain.modified, np.ascontiguousarray(Q), out)
        kern(*args)  # compile or load from cache before timing
        return (lambda: kern(*args)), Q.shape[0]
    raise ValueError(f"unknown implementation {impl!r} (have {IMPLS})")


def time_robot(chain, impls, reps: int, calls: int, batch: int, warmup: int, rng: np.random.Generator):
    """Timing samples for one robot.

    Parameters
    ----------
    chain : pipeline.kinematics.Chain
    impls : list of str, subset of :data:`IMPLS`
    reps : int
        Timed blocks per (implementation, algebra).
    calls : int
        FKs per block for the per-call implementations (python, numpy).
    batch : int
        Configurations per batch call (numpy_batch, numba).
    warmup : int
        Untimed blocks before the first timed one.
    rng : numpy.random.Generator
        Draws the joint configurations, uniform in [-pi, pi) (the same for both algebras).

    Returns
    -------
    list of dict
        ``{impl, algebra, rep, ns_per_fk, fks}`` per timed block.
    """
    Q = rng.uniform(-np.pi, np.pi, size=(max(calls, batch), chain.n))
    rows = []
    for impl in impls:
        nq = batch if impl in ("numpy_batch", "numba") else calls
        blocks = {alg: _block(impl, alg, chain, Q[:nq], calls) for alg in ALGEBRAS}
        for _ in range(warmup):
            for alg in ALGEBRAS:
                blocks[alg][0]()
        for rep in range(reps):
            order = ALGEBRAS if rep % 2 == 0 else ALGEBRAS[::-1]
            for alg in order:
                run, n = blocks[alg]
                t0 = time.thread_time_ns()
                run()
                dt = time.thread_time_ns() - t0
                rows.append({"impl": impl, "algebra": alg, "rep": rep, "ns_per_fk": dt / n, "fks": n})
    return rows
