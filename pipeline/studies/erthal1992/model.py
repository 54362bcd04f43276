"""Robot entry modes and conversions of Appendix 1 of 001_7601717b50b5e768.txt.

* joint points + axes + effector frame -> origins, x-axes, DH (Case 1, eqs A1.1-A1.17);
* PZ vectors -> DH (Case 2, eqs A1.18-A1.19 then Case 1 with the origins given);
* the report layout of SCARA.TXT (Appendix 3).

DH -> zero-position vectors (Case 3) and the PZ forward kinematics (eqs 3.5-3.17) are kinematics
and live in :mod:`pipeline.kinematics.zero_position` (re-exported here).

Conventions: standard DH, joint variable = DH theta (revolute) or d (prismatic) with no offsets, so
the zero position ``q0`` is the stored theta/d column of the document's tables. Lengths in the
robot's unit (mm), angles in radians (degrees only in printed reports).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.kinematics import Chain, fk_frames
from pipeline.kinematics.zero_position import PZModel, axis_angle_matrix, pz_fk, pz_from_dh  # noqa: F401  (re-exported)

PARALLEL_TOL = 1e-9  # |u1 x u2| below this: axes parallel (typed-in unit vectors are exact)
LENGTH_TOL = 1e-9    # [length] a vector shorter than this is zero


class ConversionError(ValueError):
    """The data cannot be converted (one line naming the joint and the problem)."""


def _unit(v, where: str) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v)
    if n < 1e-12:
        raise ConversionError(f"{where}: zero vector")
    return v / n


def _positive(v: np.ndarray) -> np.ndarray:
    """Sign "positive by default" (A1.6): first non-zero component positive (reproduces Fig. 6.7)."""
    for x in v:
        if abs(x) > 1e-9:
            return v if x > 0 else -v
    return v


def signed_angle(e1: np.ndarray, e2: np.ndarray, w: np.ndarray) -> float:
    """Angle from unit vector e1 to e2, positive about w (A1.12-A1.13, as atan2)."""
    return float(np.arctan2(np.cross(e1, e2) @ w, e1 @ e2))


def common_normal_foot(P1, u1, P2, u2) -> np.ndarray:
    """Point of line 2 (P2 + t u2) on the common normal with line 1 (eq. A1.2)."""
    U = u1 @ u2
    dP = P2 - P1
    t = (U * (u1 @ dP) - u2 @ dP) / (1.0 - U * U)
    return P2 + t * u2


def foot_of_perpendicular(P1, u1, Q) -> np.ndarray:
    """Foot on line P1 + t u1 of the perpendicular from Q (eq. A1.3)."""
    return P1 + ((Q - P1) @ u1) * u1


def _parallel(u1, u2) -> bool:
    return np.linalg.norm(np.cross(u1, u2)) < PARALLEL_TOL


@dataclass(frozen=True)
class DHModel:
    """DH parameters at the zero position with the frames they came from.

    Attributes
    ----------
    types : tuple of 'r' | 'p'
    a, alpha, d, theta : ndarray, shape (n,) [length, rad, length, rad]   zero-position values
    origins : ndarray, shape (n + 1, 3)     O_0..O_n (base frame)
    x_axes, z_axes : ndarray, shape (n + 1, 3)
    """

    types: tuple
    a: np.ndarray
    alpha: np.ndarray
    d: np.ndarray
    theta: np.ndarray
    origins: np.ndarray
    x_axes: np.ndarray
    z_axes: np.ndarray

    @property
    def prismatic(self) -> np.ndarray:
        return np.array([t == "p" for t in self.types])

    @property
    def q0(self) -> np.ndarray:
        """Zero position: theta for revolute, d for prismatic joints."""
        return np.where(self.prismatic, self.d, self.theta)

    def chain(self) -> Chain:
        """A pipeline Chain whose joint variable is the DH theta / d itself (no offsets)."""
        p = self.prismatic
        return Chain(self.a, self.alpha, np.where(p, 0.0, self.d), np.where(p, self.theta, 0.0), p)


def _origins(points, axes, O0, OE):
    n = len(points)
    O = np.zeros((n + 1, 3))
    O[0], O[n] = O0, OE
    for i in range(1, n):  # O_i lies on the axis of joint i+1 (z_i = u_{i+1})
        Pi, ui, Pn, un = points[i - 1], axes[i - 1], points[i], axes[i]
        if not _parallel(ui, un):
            O[i] = common_normal_foot(Pi, ui, Pn, un)                      # case A
        elif i + 1 < n and not _parallel(un, axes[i + 1]):
            O[i] = common_normal_foot(points[i + 1], axes[i + 1], Pn, un)  # case B
        else:
            O[i] = foot_of_perpendicular(Pn, un, O[i - 1])               # case C
    return O


def _x_axes(O, z, x0, u_a, u_t):
    n = len(O) - 1
    x = np.zeros((n + 1, 3))
    x[0] = x0
    for i in range(1, n):
        if not _parallel(z[i - 1], z[i]):
            x[i] = _positive(np.cross(z[i - 1], z[i]) / np.linalg.norm(np.cross(z[i - 1], z[i])))  # A1.6
        else:
            b = O[i] - O[i - 1]
            v = b - (b @ z[i - 1]) * z[i - 1]                                    # A1.7-A1.8
            x[i] = v / np.linalg.norm(v) if np.linalg.norm(v) > LENGTH_TOL else x[i - 1]  # A1.9 / coincident
    x[n] = np.cross(u_t, u_a)  # effector: y = u_t, z = u_a
    if abs(x[n] @ z[n - 1]) > 1e-9:
        raise ConversionError("effector: x = u_t x u_a is not perpendicular to the last joint axis "
                              "(needs a tool transform, not supported)")
    return x


def _dh_from_frames(types, O, x, z) -> DHModel:
    n = len(types)
    a, alpha, d, theta = (np.zeros(n) for _ in range(4))
    for i in range(1, n + 1):
        b = O[i] - O[i - 1]
        d[i - 1] = b @ z[i - 1]                                   # A1.11 (projection on z_{i-1})
        a[i - 1] = b @ x[i]                                       # A1.10
        alpha[i - 1] = signed_angle(z[i - 1], z[i], x[i])         # A1.14-A1.15
        theta[i - 1] = signed_angle(x[i - 1], x[i], z[i - 1])     # A1.16-A1.17
        resid = b - d[i - 1] * z[i - 1] - a[i - 1] * x[i]
        if np.linalg.norm(resid) > 1e-6 * max(1.0, np.linalg.norm(b)):
            raise ConversionError(f"joint {i}: origin O{i} is off the DH common normal by {np.linalg.norm(resid):.3g}")
    return DHModel(tuple(types), a, alpha, d, theta, O, x, z)


def dh_from_joint_points(types, points, axes, effector, u_a, u_t, base_origin=(0, 0, 0), base_x=(1, 0, 0)) -> DHModel:
    """Case 1 of Appendix 1: joint points and axes (base frame) -> DH at the zero position.

    Parameters
    ----------
    types : sequence of 'r' | 'p', length n
    points : array_like, shape (n, 3) [length]    a point of each joint axis
    axes : array_like, shape (n, 3)               joint axis directions (normalised here)
    effector : array_like, shape (3,)             effector origin O_n
    u_a, u_t : array_like, shape (3,)             approach (z) and orientation (y) of the effector

    Origins (A1.2/A1.3, cases A-C of Table A1.2; prismatic joints use the same three rules, our
    reading), x-axes (A1.6-A1.9, sign "positive": first non-zero component > 0), DH (A1.10-A1.17).
    """
    P = np.asarray(points, dtype=float)
    u = np.array([_unit(v, f"joint {i + 1}: axis") for i, v in enumerate(axes)])
    ua, ut = _unit(u_a, "effector u_a"), _unit(u_t, "effector u_t")
    if abs(ua @ ut) > 1e-9:
        raise ConversionError("effector: u_a and u_t are not perpendicular")
    O = _origins(P, u, np.asarray(base_origin, float), np.asarray(effector, float))
    z = np.vstack([u, ua])
    x = _x_axes(O, z, _unit(base_x, "base x"), ua, ut)
    return _dh_from_frames(types, O, x, z)


def dh_from_pz(pz: PZModel, base_x=(1, 0, 0)) -> DHModel:
    """Case 2 of Appendix 1: p_1 = b_1, p_{i+1} = p_i + b_{i+1} (A1.18-A1.19) are the origins
    O_0..O_n; x-axes and DH as in Case 1."""
    O = np.cumsum(pz.b, axis=0)
    z = np.vstack([pz.u, pz.u_a])
    x = _x_axes(O, z, np.asarray(base_x, float), pz.u_a, pz.u_t)
    return _dh_from_frames(pz.types, O, x, z)


def dh_model_from_chain(chain: Chain, types, q0) -> DHModel:
    """DH frames at q0 of a pipeline chain (for reports of catalogue robots)."""
    F = fk_frames(chain, np.asarray(q0, float))
    Fe = F.copy()
    Fe[-1] = F[-1] @ chain.tool
    th, dd = chain.joint_dh(np.asarray(q0, float))
    return DHModel(tuple(types), chain.a.copy(), chain.alpha.copy(), dd, th, Fe[:, :3, 3], Fe[:, :3, 0], Fe[:, :3, 2])


def report_txt(name: str, dh: DHModel, pz: PZModel, points=None, axes=None, limits=None) -> str:
    """The robot report in the layout of SCARA.TXT (Appendix 3; graphics block omitted).

    Joint positions default to the DH origins O_{i-1} (points on each joint axis) when the robot
    was not entered as joint points.
    """
    n = len(dh.types)
    rnd = lambda v: np.round(np.asarray(v, float), 6) + 0.0  # no "-0.0000" in print
    P = rnd(points) if points is not None else dh.origins[:-1]
    U = rnd(axes) if axes is not None else rnd(dh.z_axes[:-1])
    P = rnd(P)
    dh = DHModel(dh.types, rnd(dh.a), dh.alpha, rnd(dh.d), dh.theta, rnd(dh.origins), rnd(dh.x_axes), rnd(dh.z_axes))
    pz = PZModel(pz.types, rnd(pz.b), rnd(pz.u), rnd(pz.u_a), rnd(pz.u_t), pz.q0)
    deg = np.degrees
    out = [f"NOME: {name.upper()}", f"N.GRAUS DE LIBERDADE: {n}", "",
           "JUNTA\tTIPO\tPOSIÇÃO\tORIENTAÇÃO\tLIM.POSIÇÃO\tLIM.VELOC\tLIM.ACEL"]
    for i in range(n):
        lo, hi = (limits[i] if limits is not None else (np.nan, np.nan))
        conv = (lambda v: v) if dh.types[i] == "p" else deg
        s_hi = f"s: {conv(hi):.3f}" if np.isfinite(hi) else "s: -"
        s_lo = f"i: {conv(lo):.3f}" if np.isfinite(lo) else "i: -"
        out.append(f"{i + 1}\t{dh.types[i]}\t{P[i, 0]:.2f}\t{U[i, 0]:.4f}\t{s_hi}\t-\t-")
        out.append(f"\t\t{P[i, 1]:.2f}\t{U[i, 1]:.4f}\t{s_lo}")
        out.append(f"\t\t{P[i, 2]:.2f}\t{U[i, 2]:.4f}")
    e = dh.origins[-1]
    out += ["", "EFETUADOR:\tPOSIÇÃO\tDIREÇÃO\tORIENTAÇÃO"]
    for k in range(3):
        out.append(f"\t{e[k]:.2f}\t{pz.u_a[k]:.4f}\t{pz.u_t[k]:.4f}")
    out += ["", "PARÂMETROS DE DENAVIT-HARTENBERG", "i\tCOMPR.\tTORÇÃO\tDESLOC.\tÂNGULO"]
    for i in range(n):
        out.append(f"{i + 1}\t{dh.a[i]:.2f}\t{deg(dh.alpha[i]):.2f}\t{dh.d[i]:.2f}\t{deg(dh.theta[i]):.2f}")
    out += ["", "VETORES DA POSIÇÃO-ZERO", "i\tb[i]\t\t\tu[i]"]
    for i in range(n + 1):
        b = pz.b[i]
        row = f"{i + 1}\t{b[0]:.2f}\t{b[1]:.2f}\t{b[2]:.2f}"
        if i < n:
            row += f"\t{pz.u[i, 0]:.4f}\t{pz.u[i, 1]:.4f}\t{pz.u[i, 2]:.4f}"
        out.append(row)
    out += ["", "APROXIMAÇÃO / ORIENTAÇÃO DO EFETUADOR",
            "ua\t" + "\t".join(f"{v:.4f}" for v in pz.u_a), "ut\t" + "\t".join(f"{v:.4f}" for v in pz.u_t)]
    out += ["", "ORIGENS DOS SISTEMAS (Fig. 6.6)", "sistema  origem"]
    out += [f"{i}  [ " + " ".join(f"{v:8.3f}" for v in o) + " ]" for i, o in enumerate(dh.origins)]
    out += ["", "EIXOS x_i (Fig. 6.7)", "sistema  eixo x"]
    out += [f"{i}  [ " + " ".join(f"{v + 0.0:6.3f}" for v in x) + " ]" for i, x in enumerate(dh.x_axes)]
    return "\n".join(out) + "\n"


def robot_yaml(name: str, dh: DHModel, source: str, unit: str = "mm") -> str:
    """A robot file (data/robots layout) for a converted model; q0 in the notes."""
    lines = [f"name: {name}", f"source: \"{source}\"", f"length_unit: {unit}", "convention: standard", "joints:"]
    for i, t in enumerate(dh.types):
        typ = "prismatic" if t == "p" else "revolute"
        d = 0.0 if t == "p" else dh.d[i]
        off = dh.theta[i] if t == "p" else 0.0
        lines.append(f"  - {{name: \"{i + 1}\", type: {typ}, a: {dh.a[i]:.6g}, alpha: {dh.alpha[i]:.12g}, "
                     f"d: {d:.6g}, theta_offset: {off:.12g}}}")
    q0 = ", ".join(f"{v:.6g}" for v in dh.q0)
    lines.append(f"notes: \"zero position q0 = [{q0}] (rad | {unit})\"")
    return "\n".join(lines) + "\n"
