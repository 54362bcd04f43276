"""Golden snapshot of every deterministic solver's single-call results: the bit-for-bit guard of the solver rework.

What still needs exact bits is one thing: that a rework of the solvers (issue 41: the sub-packages, the one
loop) leaves today's answers unchanged to the last bit ("results bit-identical to today's on the golden
cases"). Only a stored snapshot can say that, and only on the CPU and libraries it was recorded with (numba
compiles for the host CPU, OpenBLAS picks kernels by CPU): elsewhere this test skips.

Every registered method but the peers that are not deterministic, ``trac_ik`` (two racing threads and a
wall-time budget), ``rtb_ik_nr`` and ``rtb_ik_gn`` (a failed call returns a configuration drawn from an unseeded
``rand()``, tests/solvers/test_contract.py) is run on a few catalogue robots (each method on those it applies to), on
seeded goals, through the single call (``bind(...).solve``) under several settings (defaults, restarts,
``require_limits``, both, every success criterion, another working unit). Everything but the timings must
equal the snapshot bit for bit: q, success, stop_reason, iterations, claimed_success, within_limits, errors,
traces (a digest of their bytes), analytic solutions and ``info`` (time-valued keys left out).

What the snapshot no longer holds, because tests that run on any CPU check it now: the batch call (with and
without traces) equals the single calls field by field (tests/solvers/test_contract.py's batch property over every
solver, settings variant and drawn chain; tests/solvers/core/test_driver_paths.py for the batch kernels), so equal single
calls here imply equal batches; restarts and ``require_limits`` keep their promises (a success is real and
within the limits, results finite or a reported failure, the same inputs the same output, an unreachable goal a
reported failure: tests/solvers/test_contract.py). The snapshot's single-call records are those recorded before
(the batch records were dropped from the same file, no value was recorded again).

Record the snapshot (only from a build whose results are the reference)::

    python tests/solvers/core/test_driver_golden.py --record
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
GOLDEN = ROOT / "tests" / "data" / "driver_golden" / "golden.npz"

ROBOTS = ("kuka_lwr", "ur5", "puma560", "mariano_4dof", "scara")
N_GOALS = 20
SKIP = {"trac_ik", "rtb_ik_nr", "rtb_ik_gn"}  # not deterministic (trac_ik: racing threads; rtb NR/GN: differ run to run)
# (variant name, settings mapping); the criterion variants only where the method accepts them
VARIANTS = (("default", {}), ("restarts", {"restarts": 2}), ("limits", {"require_limits": True}),
            ("limits_restarts", {"require_limits": True, "restarts": 1}),
            ("position", {"criterion": "position"}), ("dq_norm", {"criterion": "dq_norm"}),
            ("dq_norm_body", {"criterion": "dq_norm_body"}), ("mm", {"length_unit": "mm"}))
SLOW = {"pso", "nelder_mead", "bfgs", "lbfgsb", "zero_position", "geometric_iterative", "pinocchio_clik",
        "levenberg_marquardt", "inverse_jacobian_fd", "jpinv_descent", "newton_raphson", "rtb_ik_lm", "rtb_ik_nr",
        "rtb_ik_gn"}


def _problems(model, n: int, seed: int):
    """``n`` goals (robot file's unit) and starts: 14 of 20 near the goal's angles, the rest anywhere."""
    from pipeline.kinematics import fk_htm
    from pipeline.solvers import Prepared

    prep = Prepared(model, model.length_unit)
    box = prep.search_box()
    rng = np.random.default_rng(seed)
    qg = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((n, model.n))
    far = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((n, model.n))
    near = qg + rng.normal(scale=0.3, size=qg.shape) * np.where(model.chain.prismatic, 0.1 * (box[:, 1] - box[:, 0]), 1.0)
    starts = np.where((np.arange(n) < int(0.7 * n))[:, None], near, far)
    goals = np.array([fk_htm(model.chain, q) for q in qg])
    return goals, starts


def _digest(a) -> str:
    a = np.ascontiguousarray(np.asarray(a, dtype=float))
    return hashlib.sha1(repr(a.shape).encode() + a.tobytes()).hexdigest()[:16]


def _info(d: dict) -> str:
    return json.dumps({k: v for k, v in sorted(d.items()) if "time" not in k}, sort_keys=True, default=str)


def _records(results, n: int) -> dict:
    """Per-problem fields of a list of IKResult, stacked (timings left out)."""
    out = {}
    out["q"] = np.array([r.q for r in results], dtype=float).reshape(len(results), n)
    for f, dt in (("success", bool), ("stop_reason", np.int64), ("iterations", np.int64),
                  ("claimed_success", bool), ("within_limits", bool), ("position_error", float),
                  ("orientation_error", float)):
        out[f] = np.array([getattr(r, f) for r in results], dtype=dt)
    out["length_unit"] = np.array([r.length_unit for r in results])
    out["trace_sha1"] = np.array([_digest(r.trace) for r in results])
    out["trace_len"] = np.array([len(r.trace) for r in results], dtype=np.int64)
    out["n_solutions"] = np.array([-1 if r.solutions is None else len(r.solutions) for r in results], dtype=np.int64)
    out["solutions_sha1"] = np.array(["" if r.solutions is None else _digest(r.solutions) for r in results])
    out["info"] = np.array([_info(r.info) for r in results])
    return out


def _pack(key: str, rec: dict) -> dict:
    """One case's fields as two arrays (a few thousand small arrays instead of tens of thousands):
    ``key/num`` every numeric field flattened to float64 (ints and bools exactly), ``key/str`` each
    field's name, dtype kind and shape, then every string value."""
    num, strs = [], []
    for f in sorted(rec):
        v = np.asarray(rec[f])
        strs.append(f"{f}:{v.dtype.kind}:{v.shape}")
        if v.dtype.kind in "US":
            strs.extend(str(x) for x in v.ravel())
        else:
            num.append(v.astype(float).ravel())
    return {f"{key}/num": np.concatenate(num) if num else np.empty(0), f"{key}/str": np.array(strs)}


def unpack_check(num: np.ndarray, strs: np.ndarray) -> dict:
    """Inverse of :func:`_pack` (for the failure message): field -> array."""
    out, i, k, strs = {}, 0, 0, list(strs)
    while k < len(strs):
        if strs[k].startswith("num:"):  # the numbers' digest (see collect)
            out["num_digest"] = np.array([strs[k]])
            k += 1
            continue
        f, kind, shape = strs[k].split(":", 2)
        shape = tuple(int(x) for x in shape.strip("()").split(",") if x.strip())
        size = int(np.prod(shape)) if shape else 1
        k += 1
        if kind in "US":
            out[f] = np.array(strs[k:k + size]).reshape(shape)
            k += size
        elif num.size:
            out[f] = num[i:i + size].reshape(shape)
            i += size  # (a case stored as a digest only has no numbers: its num_digest tells)
    return out


def collect(only: str | None = None) -> dict:
    """Every case's arrays, keyed ``method/robot/variant/single/field``."""
    from pipeline.robots import load_robot
    from pipeline.solvers import NotApplicableError, SettingsError, bind, make_settings, names, prepare

    models = {r: load_robot(ROOT / "data" / "robots" / f"{r}.yaml") for r in ROBOTS}
    problems = {r: _problems(m, N_GOALS, 7 + k) for k, (r, m) in enumerate(models.items())}
    out = {}
    for name in names():
        if name in SKIP or (only and name != only):
            continue
        n_goals = 8 if name in SLOW else N_GOALS
        first_robot = True
        for r, model in models.items():
            try:
                prepare(name, model, make_settings(name, {}))
            except NotApplicableError:
                continue
            for vname, mapping in VARIANTS:
                if vname == "mm" and not first_robot:
                    continue
                if name in SLOW and vname in ("dq_norm_body", "limits_restarts") and not first_robot:
                    continue
                try:
                    s = make_settings(name, mapping)
                    prep = prepare(name, model, s)
                except (SettingsError, NotApplicableError):
                    continue
                goals, starts = problems[r]
                goals, starts = goals[:n_goals], starts[:n_goals]
                seeds = np.arange(n_goals, dtype=np.int64) + 1000
                key = f"{name}/{r}/{vname}"
                b = bind(name, prep, s)
                single = [b.solve(goals[i], starts[i], int(seeds[i])) for i in range(n_goals)]
                out.update(_pack(f"{key}/single", _records(single, model.n)))
            first_robot = False
    return out


def _cases(keys) -> list[str]:
    return sorted({k.split("/")[0] for k in keys if not k.startswith("__")})


def _build() -> str:
    """The libraries and machine the snapshot is bit-exact for (last bits may differ on another build):
    the versions, and the CPU the code runs on: numba compiles for the host CPU (LLVM's name for it,
    e.g. znver3 or skylake-avx512: other FMA and vector choices) and OpenBLAS picks its kernels by CPU."""
    import platform

    import llvmlite.binding as llvm
    import numba
    import scipy
    from threadpoolctl import threadpool_info

    blas = ",".join(sorted({str(i.get("architecture")) for i in threadpool_info() if i.get("internal_api") == "openblas"}))
    return (f"numpy {np.__version__}, numba {numba.__version__}, scipy {scipy.__version__}, {platform.machine()}, "
            f"cpu {llvm.get_host_cpu_name()}, openblas {blas}")


@pytest.fixture(scope="module")
def golden():
    if not GOLDEN.exists():
        pytest.skip(f"no golden snapshot ({GOLDEN}); record it with python tests/solvers/core/test_driver_golden.py --record")
    with np.load(GOLDEN, allow_pickle=False) as z:
        out = {k: z[k] for k in z.files}
    if str(out.pop("__build__", np.array(""))) != _build():
        pytest.skip(f"golden snapshot recorded on another build than this one ({_build()}): its bits do not apply "
                    "here (tests/solvers/test_contract.py checks the solvers' promises on any build)")
    return out


def _methods():
    if not GOLDEN.exists():
        return []
    with np.load(GOLDEN, allow_pickle=False) as z:
        return _cases(z.files)


@pytest.mark.parametrize("method", _methods())
def test_golden(golden, method):
    """Today's results equal the snapshot field by field, bit for bit (timings aside)."""
    now = collect(method)
    want = {k: v for k, v in golden.items() if k.split("/")[0] == method}
    assert sorted(now) == sorted(want), f"cases differ: {sorted(set(now) ^ set(want))[:10]}"
    bad = []
    for k, v in want.items():
        got = now[k]
        same = (got.shape == v.shape and got.dtype.kind == v.dtype.kind
                and np.array_equal(got, v, equal_nan=v.dtype.kind == "f"))
        if not same:
            case = k.rsplit("/", 1)[0]
            a = unpack_check(now[case + "/num"], now[case + "/str"])
            b = unpack_check(want[case + "/num"], want[case + "/str"])
            fields_ = sorted(f for f in set(a) | set(b) if f not in a or f not in b or a[f].shape != b[f].shape
                             or not np.array_equal(a[f], b[f], equal_nan=a[f].dtype.kind == "f"))
            bad.append(f"{case}: {fields_}")
    assert not bad, f"{len(bad)} cases differ, e.g. {sorted(set(bad))[:8]}"


def record() -> None:
    import time

    t = time.time()
    out = collect()
    out["__build__"] = np.array(_build())
    GOLDEN.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(GOLDEN, **out)
    print(f"{len(out)} arrays, {len(_cases(out))} methods, {GOLDEN.stat().st_size / 1e6:.2f} MB, "
          f"{time.time() - t:.0f} s")


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    if "--record" in sys.argv:
        record()
    else:
        print(__doc__)
