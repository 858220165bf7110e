#!/usr/bin/env bash
# The Python package as a user installs it: `pip install .` into a fresh venv (scikit-build-core
# builds the module; pyproject.toml), `import portaslam` outside the checkout, then tests/python
# against the installed package. Part of README's test command (ci/test.sh), after the main build,
# whose portaslam program the tests compare against. Needs PyPI for the build requirements
# (scikit-build-core, pybind11) and plyfile; numpy and pytest are Debian's (ci/setup.sh).
#   bash ci/python-package.sh            (build folder: $PORTA_BUILD_DIR, default build)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
repo="$(pwd)"

build_dir="$(cd "${PORTA_BUILD_DIR:-build}" && pwd)"
program="$build_dir/apps/portaslam"
if [ ! -x "$program" ]; then
  echo "python-package: $program is missing: build first (bash ci/build.sh)" >&2
  exit 1
fi
env_dir="$build_dir/pip-env"
work="$build_dir/pip-test"
rm -rf "$env_dir" "$work"
mkdir -p "$work"
bash ci/python-env.sh "$env_dir" > /dev/null

start=$(date +%s)
# The CMake build folder is kept between runs, so that a second install is incremental.
"$env_dir/bin/python" -m pip install --quiet --disable-pip-version-check \
    --config-settings=build-dir="$build_dir/pip-build" "$repo"
echo "python-package: pip install . took $(( $(date +%s) - start )) s"

cd "$work"
"$env_dir/bin/python" - "$env_dir" <<'PY'
import pathlib, sys
import portaslam
where = pathlib.Path(portaslam.__file__).resolve()
assert pathlib.Path(sys.argv[1]).resolve() in where.parents, f"imported {where}, not the installed package"
usable = [b["name"] for b in portaslam.backends() if b["available"]]
print(f"python-package: import portaslam {portaslam.__version__} from {where.parent}; backends here: {', '.join(usable)}")
PY

"$program" render --path street-loop --count 30 --threads 2 --quiet --out "$work/sequence"
env -u PYTHONPATH PORTASLAM_BIN="$program" PORTA_FRONTEND_CALL="$build_dir/tests/porta_frontend_call" \
    PORTA_TEST_SEQUENCE="$work/sequence" PORTA_TEST_WORK="$work/tests" PORTA_SOURCE_DIR="$repo" \
    "$env_dir/bin/python" -m pytest -q -p no:cacheprovider "$repo/tests/python"
echo "python-package: the installed package passed tests/python"
