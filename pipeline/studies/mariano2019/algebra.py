"""HTM and unit-DQ chain products in pure Python, generic over the scalar type.

Run on floats they compute (host timing, pure Python); run on
:class:`~pipeline.studies.mariano2019.counting.Counted` they also count
(eqs. 21-22 of 003_8b306f4736fa5051.txt). Conventions are those of :mod:`pipeline.kinematics`
(standard DH ``Rz(theta) Tz(d) Tx(a) Rx(alpha)``, modified DH ``Rx(alpha) Tx(a) Rz(theta) Tz(d)``,
DQ ``(w, x, y, z, w_d, x_d, y_d, z_d)``, Hamilton product, ``t = 2 q_d q_r*``); the tests check
them against :func:`pipeline.kinematics.fk_htm` / :func:`~pipeline.kinematics.fk_dq` to 1e-12.

Two ways to run a chain (``general``):

* ``general=True``: the document's model (Adorno 2011): each link is built from its four DH
  parameters as run-time values (4 trig each), every product is a general 4x4 / DQ product that
  does not know which entries are 0 or 1 (:func:`~.counting.var` lifts them).
* ``general=False``: constant folding: a link's alpha and its zero lengths are compile-time
  constants (trig of a constant is free, products with a constant 0 vanish); joint values and
  non-zero lengths stay run-time values. Nothing else is simplified by hand.
"""

from __future__ import annotations

from pipeline.studies.mariano2019 import counting as K

Mat = list  # 4x4 list of rows


def htm_link(a, alpha, d, theta, modified: bool = False) -> Mat:
    """One DH link as a 4x4 list (6 mul, 4 trig when all four parameters are run-time values)."""
    ct, st, ca, sa = K.cos(theta), K.sin(theta), K.cos(alpha), K.sin(alpha)
    if modified:
        return [[ct, -st, 0.0, a],
                [st * ca, ct * ca, -sa, -(sa * d)],
                [st * sa, ct * sa, ca, ca * d],
                [0.0, 0.0, 0.0, 1.0]]
    return [[ct, -(st * ca), st * sa, a * ct],
            [st, ct * ca, -(ct * sa), a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0]]


def htm_mul(A: Mat, B: Mat, general: bool = True) -> Mat:
    """4x4 product (64 mul, 48 add when ``general``)."""
    if general:
        A = [[K.var(x) for x in row] for row in A]
        B = [[K.var(x) for x in row] for row in B]
    C = []
    for i in range(4):
        Ai = A[i]
        row = []
        for j in range(4):
            s = Ai[0] * B[0][j]
            for k in range(1, 4):
                s = s + Ai[k] * B[k][j]
            row.append(s)
        C.append(row)
    return C


def htm_translation(T: Mat) -> tuple:
    """Position of a pose: its last column (no operation)."""
    return T[0][3], T[1][3], T[2][3]


def q_mul(p, q) -> list:
    """Hamilton product of two quaternions (w-first): 16 mul, 12 add in general."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return [pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw]


def dq_link(a, alpha, d, theta, modified: bool = False) -> list:
    """One DH link as a unit DQ (standard: eq. 16 of 003 written out; 12 mul, 4 add, 4 trig, 4 scale).

    The dual part reuses the products of the real part, as in Adorno's count: with
    ``r = (ca ct, sa ct, sa st, ca st)`` the dual part is
    ``(-a/2 sa ct - d/2 ca st, a/2 ca ct - d/2 sa st, a/2 ca st + d/2 sa ct, -a/2 sa st + d/2 ca ct)``.
    """
    ht, ha = theta * 0.5, alpha * 0.5
    ct, st, ca, sa = K.cos(ht), K.sin(ht), K.cos(ha), K.sin(ha)
    if modified:
        # Rx(alpha) Tx(a) Rz(theta) Tz(d): r = (ca ct, sa ct, -sa st, ca st), t = (a, -sin(alpha) d, cos(alpha) d)
        r = [ca * ct, sa * ct, -(sa * st), ca * st]
        sal, cal = 2.0 * (sa * ca), ca * ca - sa * sa
        t = [0.0, a, -(sal * d), cal * d]
        dual = q_mul(t, r)
        return r + [x * 0.5 for x in dual]
    a2, d2 = a * 0.5, d * 0.5
    cc, sc, ss, cs = ca * ct, sa * ct, sa * st, ca * st
    return [cc, sc, ss, cs,
            -(a2 * sc) - d2 * cs,
            a2 * cc - d2 * ss,
            a2 * cs + d2 * sc,
            -(a2 * ss) + d2 * cc]


def dq_mul(P, Q, general: bool = True) -> list:
    """DQ product ``(p_r q_r, p_r q_d + p_d q_r)``: 48 mul, 40 add when ``general``."""
    if general:
        P = [K.var(x) for x in P]
        Q = [K.var(x) for x in Q]
    real = q_mul(P[:4], Q[:4])
    d1 = q_mul(P[:4], Q[4:])
    d2 = q_mul(P[4:], Q[:4])
    return real + [d1[i] + d2[i] for i in range(4)]


def dq_translation(Q) -> tuple:
    """Position of a unit DQ, eq. 18 of 003: ``t = 2 q_d q_r*`` (vector part): 12 mul, 9 add, 3 scale."""
    q1, q2, q3, q4, q5, q6, q7, q8 = Q
    x = -(q2 * q5) + q1 * q6 - q4 * q7 + q3 * q8
    y = -(q3 * q5) + q4 * q6 + q1 * q7 - q2 * q8
    z = -(q4 * q5) - q3 * q6 + q2 * q7 + q1 * q8
    return 2.0 * x, 2.0 * y, 2.0 * z


def _params(chain, q, general: bool):
    """Per-link (a, alpha, d, theta) with run-time values lifted as the mode asks."""
    out = []
    for i in range(len(q)):
        a, alpha, d, off = (float(chain.a[i]), float(chain.alpha[i]), float(chain.d[i]),
                            float(chain.theta_offset[i]))
        if bool(chain.prismatic[i]):
            theta, d = off, d + q[i]
        else:
            theta = q[i] + off if off != 0.0 else q[i]
        if general:
            a, alpha, d, theta = (K.var(x) for x in (a, alpha, d, theta))
        else:
            a = K.var(a) if a != 0.0 else 0.0
            d = K.var(d) if not isinstance(d, K.Counted) and d != 0.0 else d
        out.append((a, alpha, d, theta))
    return out


def fk_htm_chain(chain, q, general: bool = True, parts: list | None = None) -> Mat:
    """Tip pose of the DH chain (no base/tool) as a 4x4 list.

    ``parts``, when a list, receives ``(stage, index, OpCounts)`` per link and per product while
    counting (Gráficos 2-3).
    """
    return _fk_chain(htm_link, htm_mul, chain, q, general, parts)


def fk_dq_chain(chain, q, general: bool = True, parts: list | None = None) -> list:
    """Tip pose of the DH chain (no base/tool) as a unit DQ list of 8 (see :func:`fk_htm_chain`)."""
    return _fk_chain(dq_link, dq_mul, chain, q, general, parts)


def _fk_chain(link, mul, chain, q, general: bool, parts: list | None):
    """Product of the chain's link transforms in one algebra (``link`` builds one, ``mul`` multiplies)."""
    if chain.convention == "general":
        raise ValueError("the operation-counting chain takes a DH table (standard or modified); this robot file "
                         "is in the general URDF-style form")
    mod = chain.convention == "modified"
    T = None
    for i, (a, alpha, d, theta) in enumerate(_params(chain, q, general)):
        c0 = K.snapshot() if parts is not None else None
        L = link(a, alpha, d, theta, mod)
        if parts is not None:
            parts.append(("transformation", i + 1, K.snapshot() - c0))
        if T is None:
            T = L
            continue
        c0 = K.snapshot() if parts is not None else None
        T = mul(T, L, general)
        if parts is not None:
            parts.append(("product", i, K.snapshot() - c0))
    return T


def general_chain_counts(m: int, algebra: str) -> "K.OpCounts":
    """Counts of the general m-link chain (eqs. 21-22): links with run-time DH parameters."""
    import numpy as np

    from pipeline.kinematics import Chain

    rng = np.random.default_rng(m)
    chain = Chain(rng.uniform(0.1, 1, m), rng.uniform(-1, 1, m), rng.uniform(0.1, 1, m), np.zeros(m),
                  np.zeros(m, bool))
    q = [K.Counted(v) for v in rng.uniform(-3, 3, m)]
    with K.counting() as c:
        (fk_htm_chain if algebra == "htm" else fk_dq_chain)(chain, q, general=True)
    return c
