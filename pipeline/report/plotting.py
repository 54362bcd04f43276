"""Off-screen matplotlib setup and a save helper (PNG for the report, SVG for print)."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# PNGs at 2x (220 dpi; the report shows them at the 110-dpi size, sharp on high-density screens)
plt.rcParams.update({"figure.dpi": 110, "savefig.dpi": 220, "axes.spines.top": False,
                     "axes.spines.right": False, "svg.hashsalt": "ik-pipeline", "svg.fonttype": "none"})
PNG_META = {"Software": None}
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
