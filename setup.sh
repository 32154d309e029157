#!/usr/bin/env bash
# Set-up and main job: installs what is missing, builds the engine, then solves a sample scene and
# prints what it cost.
set -euo pipefail
cd "$(dirname "$0")"
tools/bootstrap.sh
/usr/bin/python3.11 bench/cornell_box.py
