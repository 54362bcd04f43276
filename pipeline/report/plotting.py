"""Off-screen matplotlib setup and a save helper (PNG for the report, SVG for print)."""

from __future__ import annotations

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
    plt.close(fig)
    return files


__all__ = ["plt", "save"]
