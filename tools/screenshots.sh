#!/usr/bin/env bash
# Remakes the README's screenshots (docs/images/panel.png, docs/images/baked.png): a real Blender
# window on a virtual display (Xvfb) bakes sample_blends/cornell_box.blend with the add-on from
# addon/ and the engine from build/engine (built here if missing), then saves what it shows.
set -euo pipefail
cd "$(dirname "$0")/.."

tools/install_packages.sh xvfb xauth
compgen -G "build/engine/radiosity_engine*.so" > /dev/null || tools/bootstrap.sh

out="${1:-docs/images}"
# Software OpenGL on the virtual display; the UI's own events are simulated (the sidebar's tab).
xvfb-run -a -s "-screen 0 1600x900x24" \
  blender --factory-startup --enable-event-simulate --window-geometry 0 0 1600 900 \
    sample_blends/cornell_box.blend --python-exit-code 1 --python tools/screenshots.py -- "$out"
ls -l "$out"/panel.png "$out"/baked.png
