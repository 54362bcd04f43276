"""Robot files from and to URDF (written only after they read back and agree)."""

from __future__ import annotations

from pathlib import Path

from pipeline.errors import UsageError
from pipeline.names import check_name


def _write_checked(out: Path, text: str, check) -> None:
    """Write ``text`` to ``out`` only after ``check(tmp_path)`` accepted it (temp file, then rename)."""
    import os
    import shutil
    import tempfile

    out.parent.mkdir(parents=True, exist_ok=True)
    tmpdir = Path(tempfile.mkdtemp(prefix=".tmp-", dir=out.parent))
    try:
        tmp = tmpdir / out.name  # same file name: a robot file's name must equal its stem
        tmp.write_text(text)
        check(tmp)
        os.replace(tmp, out)
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)



def import_urdf(urdf, base: str, tip: str, out, *, name: str | None = None, length_unit: str = "m",
                xacro_args: dict | None = None, xacro_paths=()) -> str:
    """Write ``out`` (a robot file, general joint form) from the URDF chain ``base`` ... ``tip``; returns what to print.
    ``xacro_args``/``xacro_paths``: a xacro file's arguments and the folders besides its own it may read."""
    from pipeline.urdf import imported_yaml

    return _import_chain(urdf, base, tip, out, name, "URDFImportError", "links",
                         lambda n: imported_yaml(urdf, base, tip, name=n, length_unit=length_unit,
                                                 xacro_args=xacro_args, xacro_paths=xacro_paths))


def import_mjcf(mjcf, base: str, tip: str, out, *, name: str | None = None, length_unit: str = "m") -> str:
    """Write ``out`` (a robot file, general joint form) from the MJCF chain ``base`` ... ``tip`` (bodies, or a
    site as the tip), read with MuJoCo's own parser; the same checks and one-line errors as :func:`import_urdf`."""
    from pipeline.mjcf import imported_mjcf_yaml

    return _import_chain(mjcf, base, tip, out, name, "MJCFImportError", "bodies",
                         lambda n: imported_mjcf_yaml(mjcf, base, tip, name=n, length_unit=length_unit))


def _import_chain(src, base: str, tip: str, out, name, error: str, what: str, make_text) -> str:
    """Write the robot file ``make_text(name)`` to ``out`` once it loads; errors in one line (``error``: prefix)."""
    import re

    from pipeline.robots import RobotFileError, load_robot
    from pipeline.urdf import URDFImportError
    from pipeline.yamlio import load_yaml

    out = Path(out)
    name = name or out.stem
    check_name(name, "--name" if name != out.stem else f"--out {out}: the robot's name (the file name)")
    if name != out.stem:
        raise UsageError(f"--name {name!r}: a robot file's name must equal its file name; use --out "
                       f"{out.with_name(name + (out.suffix or '.yaml'))}")
    try:
        text = make_text(name)
    except URDFImportError as exc:  # MJCFImportError is one
        raise UsageError(f"{error}: {exc}") from None

    def check(tmp: Path) -> None:
        """The robot file's own checks (joint count, sane maxima), reported against the source file and its joint."""
        try:
            load_robot(tmp)
        except RobotFileError as exc:
            why = str(exc).removeprefix(f"{tmp}: ")
            names = [j.get("name") for j in load_yaml(tmp, "imported robot file").get("joints", [])]
            i = re.match(r"joint (\d+): ", why)
            joint = f" (joint {names[int(i.group(1)) - 1]!r})" if i and int(i.group(1)) <= len(names) else ""
            raise UsageError(f"{error}: {src}: the imported chain breaks a robot-file limit: "
                             f"{why}{joint}") from None

    _write_checked(out, text, check)
    model = load_robot(out)
    return (f"wrote {out}: {model.n} joints ({''.join('P' if p else 'R' for p in model.chain.prismatic)}), "
            f"{what} {base} -> {tip}, lengths in {model.length_unit}")



def export_urdf(robot, out, *, name: str | None = None) -> str:
    """Write ``out`` (URDF, metres, links base_link ... tool0) from a robot file; re-imported and checked first."""
    import numpy as np

    from pipeline.kinematics import fk_htm
    from pipeline.robots import load_robot, parse_robot
    from pipeline.urdf import URDFImportError, import_urdf, to_urdf

    model = load_robot(robot)
    text = to_urdf(model, name=name)

    def check(tmp: Path) -> None:
        try:
            back = parse_robot(import_urdf(tmp, "base_link", "tool0", name=model.name, length_unit=model.length_unit),
                               str(tmp))
        except URDFImportError as exc:
            raise UsageError(f"the written URDF does not import back ({exc})") from None
        rng = np.random.default_rng(0)
        lo = np.where(np.isfinite(model.limits[:, 0]), model.limits[:, 0], -np.pi)
        hi = np.where(np.isfinite(model.limits[:, 1]), model.limits[:, 1], np.pi)
        q = rng.uniform(lo, hi, (20, model.n))
        T0, T1 = fk_htm(model.chain, q), fk_htm(back.chain, q)
        tol = 1e-9 * (1.0 + np.abs(T0[..., :3, 3]).max())
        if back.n != model.n or not np.allclose(T0, T1, rtol=0, atol=tol):
            raise UsageError(f"{model.path}: the written URDF's forward kinematics differs from the robot file's "
                           f"(max {np.abs(T0 - T1).max():.3g}); not written")

    _write_checked(Path(out), text, check)
    return f"wrote {out}: {model.n} joints, links base_link -> tool0, lengths in m"
