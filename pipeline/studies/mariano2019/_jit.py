"""Compiled (numba) HTM and DQ forward kinematics over a batch, for the host speed comparison.

Same operations as :mod:`.algebra` with ``general=True`` (general link, full products), written
with scalar loops so the compiled code does exactly that work; the batch loop is inside the kernel
so the per-FK time excludes the Python call. Revolute and prismatic joints, standard or modified DH;
no base or tool (as :func:`.algebra.fk_htm_chain`). Output: tip positions (B, 3).
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def fk_htm_batch(a, alpha, d, off, prism, modified, Q, out):
    n = a.shape[0]
    T = np.empty((4, 4))
    L = np.empty((4, 4))
    C = np.empty((4, 4))
    for b in range(Q.shape[0]):
        for i in range(n):
            th = off[i] if prism[i] else Q[b, i] + off[i]
            di = d[i] + Q[b, i] if prism[i] else d[i]
            ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(alpha[i]), math.sin(alpha[i])
            if modified:
                L[0, 0] = ct; L[0, 1] = -st; L[0, 2] = 0.0; L[0, 3] = a[i]
                L[1, 0] = st * ca; L[1, 1] = ct * ca; L[1, 2] = -sa; L[1, 3] = -sa * di
                L[2, 0] = st * sa; L[2, 1] = ct * sa; L[2, 2] = ca; L[2, 3] = ca * di
            else:
                L[0, 0] = ct; L[0, 1] = -st * ca; L[0, 2] = st * sa; L[0, 3] = a[i] * ct
                L[1, 0] = st; L[1, 1] = ct * ca; L[1, 2] = -ct * sa; L[1, 3] = a[i] * st
                L[2, 0] = 0.0; L[2, 1] = sa; L[2, 2] = ca; L[2, 3] = di
            L[3, 0] = 0.0; L[3, 1] = 0.0; L[3, 2] = 0.0; L[3, 3] = 1.0
            if i == 0:
                T[:, :] = L
            else:
                for r in range(4):
                    for c in range(4):
                        s = T[r, 0] * L[0, c]
                        for k in range(1, 4):
                            s += T[r, k] * L[k, c]
                        C[r, c] = s
                T[:, :] = C
        out[b, 0] = T[0, 3]
        out[b, 1] = T[1, 3]
        out[b, 2] = T[2, 3]


@numba.njit(cache=True)
def _qmul(p0, p1, p2, p3, q0, q1, q2, q3):
    return (p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0)


@numba.njit(cache=True)
def fk_dq_batch(a, alpha, d, off, prism, modified, Q, out):
    n = a.shape[0]
    P = np.empty(8)
    L = np.empty(8)
    for b in range(Q.shape[0]):
        for i in range(n):
            th = off[i] if prism[i] else Q[b, i] + off[i]
            di = d[i] + Q[b, i] if prism[i] else d[i]
            ct, st = math.cos(0.5 * th), math.sin(0.5 * th)
            ca, sa = math.cos(0.5 * alpha[i]), math.sin(0.5 * alpha[i])
            if modified:
                r0, r1, r2, r3 = ca * ct, sa * ct, -sa * st, ca * st
                sal, cal = 2.0 * sa * ca, ca * ca - sa * sa
                t1, t2, t3 = a[i], -sal * di, cal * di
                e0, e1, e2, e3 = _qmul(0.0, t1, t2, t3, r0, r1, r2, r3)
                L[0] = r0; L[1] = r1; L[2] = r2; L[3] = r3
                L[4] = 0.5 * e0; L[5] = 0.5 * e1; L[6] = 0.5 * e2; L[7] = 0.5 * e3
            else:
                a2, d2 = 0.5 * a[i], 0.5 * di
                cc, sc, ss, cs = ca * ct, sa * ct, sa * st, ca * st
                L[0] = cc; L[1] = sc; L[2] = ss; L[3] = cs
                L[4] = -a2 * sc - d2 * cs; L[5] = a2 * cc - d2 * ss
                L[6] = a2 * cs + d2 * sc; L[7] = -a2 * ss + d2 * cc
            if i == 0:
                P[:] = L
            else:
                r = _qmul(P[0], P[1], P[2], P[3], L[0], L[1], L[2], L[3])
                x = _qmul(P[0], P[1], P[2], P[3], L[4], L[5], L[6], L[7])
                y = _qmul(P[4], P[5], P[6], P[7], L[0], L[1], L[2], L[3])
                P[0] = r[0]; P[1] = r[1]; P[2] = r[2]; P[3] = r[3]
                P[4] = x[0] + y[0]; P[5] = x[1] + y[1]; P[6] = x[2] + y[2]; P[7] = x[3] + y[3]
        q1, q2, q3, q4, q5, q6, q7, q8 = P[0], P[1], P[2], P[3], P[4], P[5], P[6], P[7]
        out[b, 0] = 2.0 * (-q2 * q5 + q1 * q6 - q4 * q7 + q3 * q8)
        out[b, 1] = 2.0 * (-q3 * q5 + q4 * q6 + q1 * q7 - q2 * q8)
        out[b, 2] = 2.0 * (-q4 * q5 - q3 * q6 + q2 * q7 + q1 * q8)
