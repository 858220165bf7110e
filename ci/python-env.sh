#!/usr/bin/env bash
# Makes the Python environment the tests use and prints its folder: a venv on Debian's python3
# (ci/setup.sh installs it with numpy, pytest and pybind11), seeing the system's packages, plus
# plyfile from PyPI (pinned, without its dependencies: numpy is Debian's; no Debian 12 package has
# plyfile), the PLY reader the map-export tests use.
#   bash ci/python-env.sh [FOLDER]     (default: $PORTA_BUILD_DIR/python-env, i.e. build/python-env)
# PORTA_PYTHON picks another interpreter (default /usr/bin/python3, else python3 on PATH).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

venv="${1:-${PORTA_BUILD_DIR:-build}/python-env}"
python="${PORTA_PYTHON:-}"
if [ -z "$python" ]; then
  if [ -x /usr/bin/python3 ]; then python=/usr/bin/python3; else python=python3; fi
fi
plyfile_version=1.1.5

if [ ! -x "$venv/bin/python" ]; then
  "$python" -m venv --system-site-packages "$venv" >&2
fi
if ! "$venv/bin/python" -c "import plyfile" 2>/dev/null; then
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps "plyfile==$plyfile_version" >&2
fi
for module in numpy pytest plyfile; do
  if ! "$venv/bin/python" -c "import $module" 2>/dev/null; then
    echo "python-env: $venv has no '$module' (run ci/setup.sh: python3-numpy, python3-pytest)" >&2
    exit 1
  fi
done
cd "$venv" && pwd
