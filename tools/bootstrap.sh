#!/usr/bin/env bash
# Installs the Debian packages the project needs (only those missing) and builds the engine.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(blender python3-numpy pybind11-dev libembree-dev libtbb-dev libosd-dev libglm-dev python3-dev
          python3-pytest python3-distributed libgtest-dev cmake g++ make
          xvfb xauth)   # an interactive Blender on a virtual display (tests/addon/test_live_update_worker.py)
tools/install_packages.sh "${packages[@]}"

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release > build.log 2>&1 || { cat build.log; exit 1; }
cmake --build build -j"$(nproc)" >> build.log 2>&1 || { tail -50 build.log; exit 1; }
rm -f build.log
