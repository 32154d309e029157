#!/usr/bin/env bash
# Every test: installs what is missing, builds, then runs the C++ tests (ctest) and the Python ones.
set -euo pipefail
cd "$(dirname "$0")"
tools/bootstrap.sh
(cd build && ctest --output-on-failure -j2)
