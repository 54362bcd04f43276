#!/usr/bin/env bash
# System packages the tests need besides Python's: headless Chromium and its WebDriver (Debian's
# `chromium`, `chromium-driver`), used by tests/test_browser.py to render the report as a reader
# would. Needs root (or sudo). Idempotent: does nothing when /usr/bin/chromium is present.
set -euo pipefail
PKGS="chromium chromium-driver fonts-dejavu-core"
if command -v chromium >/dev/null; then
    echo "Chromium present: $(chromium --version 2>/dev/null | head -n1)"
    exit 0
fi
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends $PKGS
chromium --version | head -n1
