#!/usr/bin/env bash
# placo's own environment for benchmarks/bench_placo.py (issue 43).
#
# placo 0.10.2 requires pin==3.8.0; the project's lock has pin 4.1.0, so placo cannot share the
# project's .venv. This script makes a separate venv (default /tmp/placo-venv; first argument or
# PLACO_VENV overrides) and installs placo with its pinned pin and the rest of its dependencies at
# the exact versions pip resolved for placo==0.10.2 on 2026-11-29 (CPython 3.11, x86_64 Linux).
# It never touches the project's .venv or requirements.lock.
#
#   bash benchmarks/placo_env.sh [VENV_DIR]
#   PYTHON=python3.11 bash benchmarks/placo_env.sh    # the interpreter that makes the venv
set -euo pipefail

VENV="${1:-${PLACO_VENV:-/tmp/placo-venv}}"
PYTHON="${PYTHON:-python3}"
case "$VENV" in
  */.venv|*/.venv/|.venv|.venv/) echo "placo_env.sh: refusing $VENV: a project's .venv is never placo's" >&2; exit 2 ;;
esac
if [ -x "$VENV/bin/python" ]; then  # an existing venv: only placo's own (its pin 3.8.0, or no pin yet)
  have="$("$VENV/bin/python" -c 'import importlib.metadata as m
try: print(m.version("pin"))
except m.PackageNotFoundError: print("none")')"
  if [ "$have" != "3.8.0" ] && [ "$have" != "none" ]; then
    echo "placo_env.sh: refusing $VENV: it has pin $have, which placo's pin 3.8.0 would replace" >&2; exit 2
  fi
fi

# placo 0.10.2's whole dependency set, every version exact (pip install --dry-run --report placo==0.10.2)
PINS=(
  placo==0.10.2 pin==3.8.0 libpinocchio==3.8.0 numpy==2.3.5
  eigenpy==3.12.0 coal==3.0.2 libcoal==3.0.2
  cmeel==0.62.0 cmeel-assimp==6.0.5 cmeel-boost==1.89.0 cmeel-console-bridge==1.0.2.3 cmeel-octomap==1.10.0
  cmeel-qhull==8.0.2.1 cmeel-tinyxml2==10.0.0 cmeel-urdfdom==4.0.1 cmeel-zlib==1.3.2 rhoban-cmeel-jsoncpp==1.9.4.9
  meshcat==0.3.2 ischedule==1.2.7 ipython==9.18.1 ipython_pygments_lexers==1.1.1 jedi==0.20.1 parso==0.8.7
  matplotlib-inline==0.2.2 pexpect==4.9.0 ptyprocess==0.7.0 prompt_toolkit==3.0.53 wcwidth==0.9.4 Pygments==2.21.0
  stack-data==0.6.3 asttokens==3.0.2 executing==2.3.0 pure_eval==0.2.4 traitlets==5.16.1 typing_extensions==4.16.0
  pillow==13.0.0 pyngrok==9.1.0 PyYAML==6.0.4 pyzmq==27.3.0 tornado==6.6.1 u-msgpack-python==2.8.0 psutil==7.2.2
)

"$PYTHON" -m venv "$VENV"
cd "$(dirname "$VENV")"  # never inside a repository
"$VENV/bin/python" -m pip install --no-deps "${PINS[@]}"
"$VENV/bin/python" -m pip check
"$VENV/bin/python" - <<'PY'
import importlib.metadata as md
import placo, pinocchio, numpy
print("placo", md.version("placo"), "| pin", md.version("pin"), "| numpy", numpy.__version__)
PY
