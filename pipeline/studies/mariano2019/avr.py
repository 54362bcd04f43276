"""Build and run generated C on a simulated ATmega328P (avr-gcc, avr-size, simavr).

Every function returns plain data; :func:`toolchain` says what is missing instead of raising, so
the workflow can record "not measured" and go on.
"""

from __future__ import annotations

import re
import shutil
import struct
import subprocess
from pathlib import Path

TOOLS = ("avr-gcc", "avr-size", "simavr")
ENABLE_HINT = ("install the AVR toolchain (Debian: `bash data/mariano2019/install_avr_toolchain.sh`, i.e. "
               "apt-get install -y gcc-avr avr-libc binutils-avr simavr) and rerun the workflow")
_CONF = re.compile(r"CONF i=(\d+) x=([0-9a-f]{8}) y=([0-9a-f]{8}) z=([0-9a-f]{8}) links=(\d+) products=(\d+) "
                   r"translation=(\d+) total=(\d+)")
_OP = re.compile(r"OP (\w+) i=(\d+) cycles=(\d+)")
# print variant: "PRINT" line, the text printed inside the timed region, then its "PCONF" line
_PRINT = re.compile(r"PRINT\.\n(.*?)PCONF i=(\d+) x=([0-9a-f]{8}) y=([0-9a-f]{8}) z=([0-9a-f]{8}) fk=(\d+) "
                    r"print=(\d+) total=(\d+) chars=(\d+)", re.S)
_VALUE = re.compile(r"-?\d+\.\d+|-?nan|-?inf|-?ovf")


class AvrError(RuntimeError):
    """A build or simulation step failed (one line with the tool and its first error line)."""


def toolchain() -> dict:
    """``{"available": bool, "missing": [...], "versions": {tool: first line of --version}}``."""
    missing = [t for t in TOOLS if shutil.which(t) is None]
    versions = {}
    for t in TOOLS:
        if t in missing:
            continue
        arg = "--help" if t == "simavr" else "--version"
        try:
            out = subprocess.run([t, arg], capture_output=True, text=True, timeout=20)
            text = (out.stdout or out.stderr).strip().splitlines()
            versions[t] = text[0] if text else ""
        except (OSError, subprocess.SubprocessError):
            missing.append(t)
    if "simavr" in versions:
        versions["simavr"] = _dpkg_version("simavr") or versions["simavr"]
    return {"available": not missing, "missing": missing, "versions": versions}


def _dpkg_version(pkg: str) -> str:
    try:
        out = subprocess.run(["dpkg-query", "-W", "-f=${Version}", pkg], capture_output=True, text=True, timeout=20)
        return f"{pkg} {out.stdout.strip()}" if out.returncode == 0 else ""
    except (OSError, subprocess.SubprocessError):
        return ""


def _run(cmd: list[str], timeout: float) -> subprocess.CompletedProcess:
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise AvrError(f"{cmd[0]}: timed out after {timeout:g} s") from None
    if out.returncode != 0:
        first = next((ln for ln in (out.stderr + out.stdout).splitlines() if "error" in ln.lower()),
                     (out.stderr or out.stdout).strip().splitlines()[:1] or [""])
        first = first if isinstance(first, str) else first[0]
        raise AvrError(f"{cmd[0]} failed (exit {out.returncode}): {first.strip()}")
    return out


def compile_c(source: str, workdir: Path, stem: str, mcu: str, cflags: list[str]) -> Path:
    """Write ``<stem>.c`` and compile it to ``<stem>.elf``; returns the ELF path."""
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    c = workdir / f"{stem}.c"
    c.write_text(source)
    elf = workdir / f"{stem}.elf"
    _run(["avr-gcc", f"-mmcu={mcu}", *cflags, "-o", str(elf), str(c), "-lm"], timeout=120)
    return elf


def section_sizes(elf: Path) -> dict:
    """``avr-size -A`` sections -> {text, data, bss, flash = text + data, sram = data + bss} [bytes]."""
    out = _run(["avr-size", "-A", str(elf)], timeout=30).stdout
    sizes = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0] in (".text", ".data", ".bss") and parts[1].isdigit():
            sizes[parts[0][1:]] = int(parts[1])
    for k in ("text", "data", "bss"):
        sizes.setdefault(k, 0)
    sizes["flash"] = sizes["text"] + sizes["data"]
    sizes["sram"] = sizes["data"] + sizes["bss"]
    return sizes


def simulate(elf: Path, mcu: str, freq_hz: int, timeout: float) -> str:
    """Run the ELF in simavr until the firmware sleeps with interrupts off; returns the UART text."""
    out = _run(["simavr", "-m", mcu, "-f", str(int(freq_hz)), str(elf)], timeout=timeout)
    text = re.sub(r"\x1b\[[0-9;]*m", "", out.stdout + out.stderr)
    if "END" not in text:
        raise AvrError(f"simavr: the firmware did not finish (no END line); output: {text.strip()[:200]!r}")
    return text


def _f32(h: str) -> float:
    return struct.unpack(">f", bytes.fromhex(h))[0]


def parse_fk_output(text: str) -> dict:
    """The harness output -> {overhead, stack_peak, confs: [{i, x, y, z, links, products, translation, total}]}."""
    confs = []
    for m in _CONF.finditer(text):
        i, x, y, z, l, p, t, tot = m.groups()
        confs.append({"i": int(i), "x": _f32(x), "y": _f32(y), "z": _f32(z), "links": int(l),
                      "products": int(p), "translation": int(t), "total": int(tot)})
    over = re.search(r"OVERHEAD (\d+)", text)
    stack = re.search(r"STACK (\d+)", text)
    if not confs or over is None or stack is None:
        raise AvrError(f"cannot parse the firmware output: {text.strip()[:200]!r}")
    return {"overhead": int(over.group(1)), "stack_peak": int(stack.group(1)), "confs": confs}


def parse_print_output(text: str) -> dict:
    """The print-variant output -> {overhead, confs: [{i, x, y, z, fk, print, total, chars, text, values}]}.

    ``text`` is what the firmware printed inside the timed region as simavr echoes it: simavr shows
    every byte below ' ' as '.' and ends its own output lines with a newline (after a '\\n' byte or
    127 bytes), so with those newlines removed ``text`` has one character per byte sent (``chars``,
    counted by the firmware, must equal ``len(text)``). ``values`` are the printed numbers.
    """
    confs = []
    for m in _PRINT.finditer(text):
        body, i, x, y, z, fk, pr, tot, n = m.groups()
        shown = body.replace("\n", "")
        values = [float(v) if v[-1].isdigit() else float("nan") for v in _VALUE.findall(shown)]
        confs.append({"i": int(i), "x": _f32(x), "y": _f32(y), "z": _f32(z), "fk": int(fk), "print": int(pr),
                      "total": int(tot), "chars": int(n), "text": shown, "values": values})
    over = re.search(r"OVERHEAD (\d+)", text)
    if not confs or over is None:
        raise AvrError(f"cannot parse the print-variant output: {text.strip()[:200]!r}")
    return {"overhead": int(over.group(1)), "confs": confs}


def parse_ops_output(text: str) -> list[dict]:
    rows = [{"op": m.group(1), "i": int(m.group(2)), "cycles": int(m.group(3))} for m in _OP.finditer(text)]
    if not rows:
        raise AvrError(f"cannot parse the operation-cost output: {text.strip()[:200]!r}")
    return rows
