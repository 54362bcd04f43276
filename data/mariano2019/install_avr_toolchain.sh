#!/usr/bin/env bash
# AVR toolchain for study mariano2019 (003_8b306f4736fa5051.txt): compiler, C library, binutils
# and the simavr simulator, from Debian/Ubuntu packages. Needs root (or sudo). Idempotent.
set -euo pipefail
PKGS="gcc-avr avr-libc binutils-avr simavr"
if command -v avr-gcc >/dev/null && command -v avr-size >/dev/null && command -v simavr >/dev/null; then
    echo "AVR toolchain present: $(avr-gcc --version | head -n1)"
    exit 0
fi
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends $PKGS
avr-gcc --version | head -n1
