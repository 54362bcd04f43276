"""Compiled dense linear algebra of the general 6R elimination: a rank-revealing QR split of the
coefficient blocks, eigenvalues of an upper Hessenberg matrix (shifted QR) and of a general one (numba's
LAPACK ``dgeev``), and the deflation of the singular pencil; arrays float64, sizes in each docstring."""

from __future__ import annotations

import math

import numba
import numpy as np
from numba.np.linalg import _LAPACK, ensure_lapack

ensure_lapack()


@numba.njit(cache=True, error_model="numpy")
def mm(A, B):
    """A @ B by loops (small matrices; no BLAS)."""
    out = np.zeros((A.shape[0], B.shape[1]))
    for r in range(A.shape[0]):
        for k in range(A.shape[1]):
            a = A[r, k]
            for c in range(B.shape[1]):
                out[r, c] += a * B[k, c]
    return out


@numba.njit(cache=True, error_model="numpy", inline="always")
def _row_scales(A):
    """Each row of ``A`` (14, 8) scaled in place by a power of two to unit size (exact: the rows' units
    differ); the factors (14,)."""
    sc = np.empty(14)
    for r in range(14):
        big = 0.0
        for c in range(8):
            big = max(big, abs(A[r, c]))
        sc[r] = 2.0 ** -math.floor(math.log2(big)) if big > 0.0 and math.isfinite(big) else 1.0
        for c in range(8):
            A[r, c] *= sc[r]
    return sc


@numba.njit(cache=True, error_model="numpy", inline="always")
def _reflectors_product(V, tau, w):
    """U (14, 14) = H₀ ⋯ H₇, each H = I − τ v vᵀ (v the columns of ``V`` (14, 8), τ ``tau`` (8,));
    ``w`` (14,) scratch."""
    U = np.zeros((14, 14))
    for r in range(14):
        U[r, r] = 1.0
    for j in range(7, -1, -1):
        for c in range(14):
            w[c] = 0.0
        for r in range(j, 14):
            vr = V[r, j]
            for c in range(14):
                w[c] += vr * U[r, c]
        for r in range(j, 14):
            f = tau[j] * V[r, j]
            for c in range(14):
                U[r, c] -= f * w[c]
    return U


@numba.njit(cache=True, error_model="numpy")
def qr_split(Q, Qp, Nl):
    """Householder QR with column pivoting of the products' coefficients ``Q`` (14, 8): ``Q Π = U R``.
    Writes the least-squares solve ``Qp`` (8, 14) = Π R⁻¹ U₁ᵀ and the left null space ``Nl`` (6, 14)
    (the last 6 columns of U, as rows); returns False when Q is rank deficient (|R₇₇| <= 1e-12 |R₀₀|).
    About 1 µs, against 20 µs for LAPACK's SVD of so small a matrix."""
    A = Q.copy()
    sc = _row_scales(A)
    V = np.zeros((14, 8))
    tau = np.zeros(8)
    perm = np.arange(8)
    w = np.empty(14)
    for j in range(8):
        best, p = -1.0, j
        for c in range(j, 8):
            nn = 0.0
            for r in range(j, 14):
                nn += A[r, c] * A[r, c]
            if nn > best:
                best, p = nn, c
        if p != j:
            for r in range(14):
                A[r, j], A[r, p] = A[r, p], A[r, j]
            perm[j], perm[p] = perm[p], perm[j]
        nrm = math.sqrt(best)
        if not nrm > 0.0:
            return False
        alpha = -nrm if A[j, j] >= 0.0 else nrm
        vv = 0.0
        for r in range(j, 14):
            V[r, j] = A[r, j]
        V[j, j] -= alpha
        for r in range(j, 14):
            vv += V[r, j] * V[r, j]
        tau[j] = 2.0 / vv
        A[j, j] = alpha
        for r in range(j + 1, 14):
            A[r, j] = 0.0
        for c in range(j + 1, 8):
            d = 0.0
            for r in range(j, 14):
                d += V[r, j] * A[r, c]
            d *= tau[j]
            for r in range(j, 14):
                A[r, c] -= d * V[r, j]
    if not abs(A[7, 7]) > 1e-12 * abs(A[0, 0]):
        return False
    U = _reflectors_product(V, tau, w)
    for k in range(6):
        for c in range(14):
            Nl[k, c] = U[c, 8 + k] * sc[c]
    Y = np.empty((8, 14))  # R Y = U₁ᵀ by back substitution
    for i in range(7, -1, -1):
        for c in range(14):
            acc = U[c, i]
            for k in range(i + 1, 8):
                acc -= A[i, k] * Y[k, c]
            Y[i, c] = acc / A[i, i]
    for i in range(8):
        for c in range(14):
            Qp[perm[i], c] = Y[i, c] * sc[c]
    return True


_RGEEV = _LAPACK().numba_ez_rgeev(numba.types.float64)  # numba's own LAPACK entry (scipy's dgeev): cacheable


@numba.njit(cache=True, error_model="numpy")
def eigvals(A, wr, wi):
    """Eigenvalues of the square ``A`` (n, n) into ``wr``, ``wi`` (n,) by LAPACK ``dgeev`` (no vectors);
    A is overwritten (LAPACK reads the C-ordered array as its transpose: the same eigenvalues).
    Returns LAPACK's info (0: done)."""
    n = A.shape[0]
    vl, vr = np.empty(1), np.empty(1)
    return _RGEEV(100, 78, 78, n, A.ctypes, n, wr.ctypes, wi.ctypes, vl.ctypes, 1, vr.ctypes, 1)  # 'd', 'N', 'N'


@numba.njit(cache=True, error_model="numpy", inline="always")
def _balance(a):
    """``a`` (n, n) balanced in place by similarity with powers of two (exact)."""
    n = a.shape[0]
    done = False
    while not done:
        done = True
        for i in range(n):
            r = 0.0
            c = 0.0
            for j in range(n):
                if j != i:
                    c += abs(a[j, i])
                    r += abs(a[i, j])
            if c != 0.0 and r != 0.0:
                g = r / 2.0
                f = 1.0
                s = c + r
                while c < g:
                    f *= 2.0
                    c *= 4.0
                g = r * 2.0
                while c > g:
                    f /= 2.0
                    c /= 4.0
                if (c + r) / f < 0.95 * s:
                    done = False
                    g = 1.0 / f
                    for j in range(n):
                        a[i, j] *= g
                    for j in range(n):
                        a[j, i] *= f


@numba.njit(cache=True, error_model="numpy", inline="always")
def _hessenberg(a):
    """``a`` (n, n) reduced in place to upper Hessenberg form by stabilized elementary similarity
    transformations (zeros below the subdiagonal)."""
    n = a.shape[0]
    for m in range(1, n - 1):
        x = 0.0
        i = m
        for j in range(m, n):
            if abs(a[j, m - 1]) > abs(x):
                x = a[j, m - 1]
                i = j
        if i != m:
            for j in range(m - 1, n):
                a[i, j], a[m, j] = a[m, j], a[i, j]
            for j in range(n):
                a[j, i], a[j, m] = a[j, m], a[j, i]
        if x != 0.0:
            for i in range(m + 1, n):
                y = a[i, m - 1]
                if y != 0.0:
                    y /= x
                    a[i, m - 1] = y
                    for j in range(m, n):
                        a[i, j] -= y * a[m, j]
                    for j in range(n):
                        a[j, m] += y * a[j, i]
    for i in range(2, n):  # below the subdiagonal: zero
        for j in range(i - 1):
            a[i, j] = 0.0


@numba.njit(cache=True, error_model="numpy", inline="always")
def _small_subdiagonal(a, nn, anorm):
    """The row l <= nn where the active block of the Hessenberg ``a`` starts (its subdiagonal entry
    negligible, set to zero; 0 when none is)."""
    for ll in range(nn, 0, -1):
        s = abs(a[ll - 1, ll - 1]) + abs(a[ll, ll])
        if s == 0.0:
            s = anorm
        if abs(a[ll, ll - 1]) + s == s:
            a[ll, ll - 1] = 0.0
            return ll
    return 0


@numba.njit(cache=True, error_model="numpy", inline="always")
def _pair(x, y, w, t, nn, wr, wi):
    """The two eigenvalues of the trailing 2 × 2 block (``x`` = a[nn, nn], ``y`` = a[nn-1, nn-1], ``w`` the
    product of the off-diagonal entries; ``t`` the shifts so far) into ``wr``, ``wi`` at nn − 1 and nn."""
    p = 0.5 * (y - x)
    q = p * p + w
    z = math.sqrt(abs(q))
    x += t
    if q >= 0.0:
        z = p + (z if p >= 0.0 else -z)
        wr[nn - 1] = wr[nn] = x + z
        if z != 0.0:
            wr[nn] = x - w / z
        wi[nn - 1] = wi[nn] = 0.0
    else:
        wr[nn - 1] = wr[nn] = x + p
        wi[nn - 1] = -z
        wi[nn] = z


@numba.njit(cache=True, error_model="numpy", inline="always")
def _francis_start(a, l, nn, x, y, w):
    """Where the double-shift sweep on rows l .. nn starts (two consecutive small subdiagonal entries),
    and its first column's (p, q, r), scaled: (m, p, q, r)."""
    m = nn - 2
    p = q = r = 0.0
    while m >= l:
        z = a[m, m]
        r = x - z
        s = y - z
        p = (r * s - w) / a[m + 1, m] + a[m, m + 1]
        q = a[m + 1, m + 1] - z - r - s
        r = a[m + 2, m + 1]
        s = abs(p) + abs(q) + abs(r)
        p /= s
        q /= s
        r /= s
        if m == l:
            break
        u = abs(a[m, m - 1]) * (abs(q) + abs(r))
        v = abs(p) * (abs(a[m - 1, m - 1]) + abs(z) + abs(a[m + 1, m + 1]))
        if u + v == v:
            break
        m -= 1
    return m, p, q, r


@numba.njit(cache=True, error_model="numpy", inline="always")
def _francis_sweep(a, l, m, nn, p, q, r):
    """One Francis double-shift QR sweep of the Hessenberg ``a`` on rows m .. nn of the active block
    l .. nn, from the first column's (p, q, r) (:func:`_francis_start`), in place."""
    x = y = z = 0.0
    for i in range(m + 2, nn + 1):
        a[i, i - 2] = 0.0
        if i != m + 2:
            a[i, i - 3] = 0.0
    for k in range(m, nn):
        if k != m:
            p = a[k, k - 1]
            q = a[k + 1, k - 1]
            r = 0.0
            if k != nn - 1:
                r = a[k + 2, k - 1]
            x = abs(p) + abs(q) + abs(r)
            if x != 0.0:
                p /= x
                q /= x
                r /= x
        s = math.sqrt(p * p + q * q + r * r)
        if p < 0.0:
            s = -s
        if s != 0.0:
            if k == m:
                if l != m:
                    a[k, k - 1] = -a[k, k - 1]
            else:
                a[k, k - 1] = -s * x
            p += s
            x = p / s
            y = q / s
            z = r / s
            q /= p
            r /= p
            for j in range(k, nn + 1):
                p = a[k, j] + q * a[k + 1, j]
                if k != nn - 1:
                    p += r * a[k + 2, j]
                    a[k + 2, j] -= p * z
                a[k + 1, j] -= p * y
                a[k, j] -= p * x
            mmin = nn if nn < k + 3 else k + 3
            for i in range(l, mmin + 1):
                p = x * a[i, k] + y * a[i, k + 1]
                if k != nn - 1:
                    p += z * a[i, k + 2]
                    a[i, k + 2] -= p * r
                a[i, k + 1] -= p * q
                a[i, k] -= p


@numba.njit(cache=True, error_model="numpy")
def eig_hess(a, wr, wi):
    """Eigenvalues of the square ``a`` (n, n) into ``wr``, ``wi`` (n,), ``a`` overwritten: balanced by
    powers of two, reduced to Hessenberg form by stabilized elementary similarity transformations,
    then the Francis double-shift QR iteration on the active block only (eigenvalues, no vectors;
    the EISPACK algorithms balanc, elmhes and hqr as Press et al., Numerical Recipes, §11.5-11.6,
    give them). Returns False for a non-finite entry or when an eigenvalue does not converge in 30
    iterations (the caller then asks LAPACK). On the deflated 16 × 16 here it takes 13-20 µs against
    LAPACK ``dgeev``'s 27-37 (the same real eigenvalues to 6e-10 on 2 000 goals; Newton polishes them after)."""
    n = a.shape[0]
    for i in range(n):
        for j in range(n):
            if not math.isfinite(a[i, j]):
                return False  # (the balancing would not end on an infinity)
    _balance(a)
    _hessenberg(a)
    # shifted QR on the Hessenberg matrix (eigenvalues only)
    anorm = 0.0
    for i in range(n):
        for j in range(max(i - 1, 0), n):
            anorm += abs(a[i, j])
    nn = n - 1
    t = 0.0
    its = 0
    total = 0
    x = y = w = 0.0
    while nn >= 0:
        l = _small_subdiagonal(a, nn, anorm)
        x = a[nn, nn]
        if l == nn:
            wr[nn] = x + t
            wi[nn] = 0.0
            nn -= 1
            its = 0
            continue
        y = a[nn - 1, nn - 1]
        w = a[nn, nn - 1] * a[nn - 1, nn]
        if l == nn - 1:
            _pair(x, y, w, t, nn, wr, wi)
            nn -= 2
            its = 0
            continue
        if its == 30 or total > 30 * n:
            return False
        if its == 10 or its == 20:  # exceptional shift
            t += x
            for i in range(nn + 1):
                a[i, i] -= x
            s = abs(a[nn, nn - 1]) + abs(a[nn - 1, nn - 2])
            x = y = 0.75 * s
            w = -0.4375 * s * s
        its += 1
        total += 1
        m, p, q, r = _francis_start(a, l, nn, x, y, w)
        _francis_sweep(a, l, m, nn, p, q, r)
    return True


@numba.njit(cache=True, error_model="numpy", inline="always")
def _pencil_at_i(pen):
    """``N(i) = N0 − N2 + i N1`` of the pencil ``pen`` (3, 12, 12) by complete-pivoting LU, 8 steps, in
    place: (ok, the factors (12, 12), the column order (12,)); ok False where a pivot vanishes or the
    rest is not below 1e-9 of the first pivot (no 4-dimensional null space)."""
    Nc = np.empty((12, 12), np.complex128)
    for r in range(12):
        for c in range(12):
            Nc[r, c] = complex(pen[0, r, c] - pen[2, r, c], pen[1, r, c])
    perm = np.arange(12)
    p0 = 0.0
    for s_ in range(8):
        pr, pc, pm = s_, s_, -1.0
        for r in range(s_, 12):
            for c in range(s_, 12):
                a = abs(Nc[r, c].real) + abs(Nc[r, c].imag)
                if a > pm:
                    pm, pr, pc = a, r, c
        if s_ == 0:
            p0 = pm
        if not pm > 0.0:
            return False, Nc, perm
        if pr != s_:
            for c in range(12):
                Nc[s_, c], Nc[pr, c] = Nc[pr, c], Nc[s_, c]
        if pc != s_:
            for r in range(12):
                Nc[r, s_], Nc[r, pc] = Nc[r, pc], Nc[r, s_]
            perm[s_], perm[pc] = perm[pc], perm[s_]
        inv = 1.0 / Nc[s_, s_]
        for r in range(s_ + 1, 12):
            f = Nc[r, s_] * inv
            for c in range(s_ + 1, 12):
                Nc[r, c] -= f * Nc[s_, c]
    for r in range(8, 12):
        for c in range(8, 12):
            if not abs(Nc[r, c].real) + abs(Nc[r, c].imag) <= 1e-9 * p0:
                return False, Nc, perm
    return True, Nc, perm


@numba.njit(cache=True, error_model="numpy", inline="always")
def _invariant_subspace(Nc, perm):
    """The companion's invariant subspace X (24, 8) for ±i from the null space of the factored pencil
    (:func:`_pencil_at_i`): for each null vector v, the columns ``[Re v; −Im v], [Im v; Re v]``."""
    X = np.empty((24, 8))
    z = np.empty(12, np.complex128)
    for k in range(4):
        for j in range(8, 12):
            z[j] = 1.0 if j == 8 + k else 0.0
        for i in range(7, -1, -1):
            acc = -Nc[i, 8 + k]
            for j in range(i + 1, 8):
                acc -= Nc[i, j] * z[j]
            z[i] = acc / Nc[i, i]
        for j in range(12):
            c = perm[j]
            X[c, 2 * k], X[12 + c, 2 * k] = z[j].real, -z[j].imag
            X[c, 2 * k + 1], X[12 + c, 2 * k + 1] = z[j].imag, z[j].real
    return X


@numba.njit(cache=True, error_model="numpy", inline="always")
def _is_invariant(comp, X):
    """comp x₂ₖ = −x₂ₖ₊₁ and comp x₂ₖ₊₁ = x₂ₖ to 1e-9 (the top half holds by the companion's form)."""
    amax, xmax, res = 0.0, 0.0, 0.0
    for r in range(12, 24):
        for c in range(24):
            amax = max(amax, abs(comp[r, c]))
    for r in range(24):
        for c in range(8):
            xmax = max(xmax, abs(X[r, c]))
    for k in range(4):
        for r in range(12, 24):
            ea, eb = 0.0, 0.0
            for c in range(24):
                ea += comp[r, c] * X[c, 2 * k]
                eb += comp[r, c] * X[c, 2 * k + 1]
            res = max(res, abs(ea + X[r, 2 * k + 1]), abs(eb - X[r, 2 * k]))
    return res <= 1e-9 * (amax + 1.0) * xmax


@numba.njit(cache=True, error_model="numpy", inline="always")
def _lu_rows(X):
    """P X = [L1; L2] U by Gaussian elimination with row pivoting, in place (L's multipliers below the
    diagonal): (ok, the row order (24,), its first 8 the pivot rows)."""
    rows = np.arange(24)
    for j in range(8):
        p, pm = j, -1.0
        for r in range(j, 24):
            if abs(X[r, j]) > pm:
                pm, p = abs(X[r, j]), r
        if not pm > 0.0:
            return False, rows
        if p != j:
            for c in range(8):
                X[j, c], X[p, c] = X[p, c], X[j, c]
            rows[j], rows[p] = rows[p], rows[j]
        for r in range(j + 1, 24):
            f = X[r, j] / X[j, j]
            X[r, j] = f  # the multiplier: L's entry
            for c in range(j + 1, 8):
                X[r, c] -= f * X[j, c]
    return True, rows


@numba.njit(cache=True, error_model="numpy")
def deflate(pen, comp, B):
    """The companion ``comp`` (24, 24) with its 8 eigenvalues at ±i removed, into ``B`` (16, 16).

    Whatever the arm, ``(1 + x3²)⁴`` divides the degree-24 determinant (Raghavan & Roth), and the
    change of variable fixes ±i: the pencil ``N(i) = N0 − N2 + i N1`` has a 4-dimensional null space
    (complete-pivoting LU, 8 steps, the rest below 1e-9 of the first pivot), whose vectors ``v`` give
    the companion's invariant subspace ``[Re v; −Im v], [Im v; Re v]`` (24, 8) for ±i, checked to
    1e-9. With P X = [L1; L2] U (row pivoting, |L| <= 1), the similarity ``[[X1, 0], [X2, I]]``
    makes P comp Pᵀ block triangular, its other eigenvalues those of ``A22 − L2 L1⁻¹ A12`` (about 7 µs
    here; the 16 × 16 eigenvalues then take about two thirds of the 24 × 24's time). Returns False
    where a check fails (the caller then solves the whole companion)."""
    ok, Nc, perm = _pencil_at_i(pen)
    if not ok:
        return False
    X = _invariant_subspace(Nc, perm)
    if not _is_invariant(comp, X):
        return False
    ok, rows = _lu_rows(X)
    if not ok:
        return False
    # W = L1⁻¹ A12 (8, 16), then B = A22 − L2 W, in the pivoted order
    W = np.empty((8, 16))
    for i in range(8):
        for c in range(16):
            acc = comp[rows[i], rows[8 + c]]
            for k in range(i):
                acc -= X[i, k] * W[k, c]
            W[i, c] = acc
    for r in range(16):
        for c in range(16):
            acc = comp[rows[8 + r], rows[8 + c]]
            for k in range(8):
                acc -= X[8 + r, k] * W[k, c]
            B[r, c] = acc
    return True
