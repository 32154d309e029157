#!/usr/bin/env bash
# Installs the add-on with its engine module where every user's Blender finds it.
set -euo pipefail
cd "$(dirname "$0")/.."
target=/usr/share/blender/scripts/addons/dynamic_radiosity
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
$sudo rm -rf "$target"
$sudo mkdir -p "$target"
$sudo cp addon/*.py "$target"/
$sudo cp build/engine/radiosity_engine*.so "$target"/
echo "Installed the add-on in $target"
