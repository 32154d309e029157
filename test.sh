#!/usr/bin/env bash
# Every test: installs what is missing, builds, installs the add-on, then runs the engine's C++ and
# Python tests (ctest) and the add-on's tests inside Blender.
set -euo pipefail
cd "$(dirname "$0")"
tools/bootstrap.sh
tools/install_addon.sh
(cd build && ctest --output-on-failure -j2)
blender -b --factory-startup --python-exit-code 1 --python tests/addon/run_pytest.py -- tests/addon -q
