#!/usr/bin/env bash
# Set-up and main job: installs what is missing, builds the engine, installs the add-on for every
# user's Blender, then bakes the Cornell box sample, saves it and renders a picture into out/.
set -euo pipefail
cd "$(dirname "$0")"
tools/bootstrap.sh
tools/install_addon.sh
blender -b --addons dynamic_radiosity sample_blends/cornell_box.blend --python-exit-code 1 \
  --python tools/main_job.py -- out 2>&1 | grep -v "^Fra:\|^Blender quit"
