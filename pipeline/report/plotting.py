"""Off-screen matplotlib setup and a save helper (PNG for the report, SVG for print)."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# PNGs at 2x (220 dpi; the report shows them at the 110-dpi size, sharp on high-density screens)
plt.rcParams.update({"figure.dpi": 110, "savefig.dpi": 220, "axes.spines.top": False,
                     "axes.spines.right": False, "svg.hashsalt": "ik-pipeline", "svg.fonttype": "none"})
PNG_META = {"Software": None}


class _ExactLinalg:
    """``numpy.linalg`` with ``norm`` (2-norm) computed element-wise: no BLAS ``ddot``."""

    def __getattr__(self, name):
        return getattr(np.linalg, name)

    @staticmethod
    def norm(x, ord=None, axis=None, keepdims=False):
        if ord is not None:
            return np.linalg.norm(x, ord=ord, axis=axis, keepdims=keepdims)
        x = np.asarray(x, dtype=float)
        return np.sqrt(np.add.reduce(x * x, axis=axis, keepdims=keepdims))


class _ExactNumpy:
    """numpy as mplot3d sees it, with ``dot`` and ``linalg.norm`` by element-wise arithmetic.

    mplot3d projects every 3-D point with ``np.dot`` (4x4 matrices, BLAS ``dgemm``), whose last bits
    follow the BLAS kernel the CPU gets (with or without fused multiply-add); antialiased PNG pixels
    and SVG ids then differ between two machines drawing the same data. Products here are summed
    term by term in index order, so a figure is the same bytes whatever the BLAS.
    """

    linalg = _ExactLinalg()

    def __getattr__(self, name):
        return getattr(np, name)

    @staticmethod
    def dot(a, b):
        a, b = np.asarray(a), np.asarray(b)
        if a.ndim not in (1, 2) or b.ndim not in (1, 2) or a.dtype.kind not in "fi" or b.dtype.kind not in "fi":
            return np.dot(a, b)
        a, b = a.astype(float), b.astype(float)
        A = a if a.ndim == 2 else a[None, :]
        B = b if b.ndim == 2 else b[:, None]
        out = A[:, 0:1] * B[0:1, :]
        for k in range(1, A.shape[1]):
            out = out + A[:, k:k + 1] * B[k:k + 1, :]
        if a.ndim == 1:
            out = out[0]
        if b.ndim == 1:
            out = out[..., 0]
        return out


def _exact_mplot3d() -> None:
    """Point mplot3d's modules at :class:`_ExactNumpy` (their drawing only; numpy itself is untouched).

    Done when this module is imported, before any figure: mplot3d computes with ``np.dot`` while 3-D
    axes are built as well as when they are drawn (applied only in :func:`save`, a quick build's 3-D
    PNG still differed under another BLAS kernel). pyplot has loaded mplot3d already, so it costs
    nothing more."""
    from mpl_toolkits.mplot3d import art3d, axes3d, proj3d

    for mod in (art3d, axes3d, proj3d):
        mod.np = _ExactNumpy()


_exact_mplot3d()
SVG_META = {"Date": None, "Creator": None}


def save(fig, out_dir: Path, stem: str, svg: bool = True) -> list[str]:
    """Save ``fig`` as ``stem.png`` (and ``stem.svg``), close it, return the file names."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    files = [f"{stem}.png"]
    fig.savefig(out_dir / files[0], metadata=PNG_META)
    if svg:
        files.append(f"{stem}.svg")
        fig.savefig(out_dir / files[1], metadata=SVG_META)
        _number_svg_ids(out_dir / files[1])
    plt.close(fig)
    return files


_SVG_ID = re.compile(r'id="([pm][0-9a-f]{10})"')  # clip paths (p...) and marker paths (m...)


def _number_svg_ids(path: Path) -> None:
    """Rename matplotlib's clip-path and marker ids (hashes of full-precision coordinates, whose last
    bits follow the BLAS kernel of the machine through mplot3d's projections) to ``clip1``,
    ``marker1``... in order of appearance, so that a figure rebuilt on another machine is the same
    bytes when everything it draws is."""
    text = path.read_text()
    names = {}
    for old in _SVG_ID.findall(text):
        kind = "clip" if old[0] == "p" else "marker"
        names.setdefault(old, f"{kind}{sum(v.startswith(kind) for v in names.values()) + 1}")
    if names:
        text = re.sub(r"\b([pm][0-9a-f]{10})\b", lambda m: names.get(m.group(1), m.group(1)), text)
        path.write_text(text)


__all__ = ["plt", "save"]
