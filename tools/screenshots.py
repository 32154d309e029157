"""The README's screenshots, taken in a real Blender window (tools/screenshots.sh runs it under Xvfb).

    blender --factory-startup --enable-event-simulate --window-geometry 0 0 1600 900 \
        sample_blends/cornell_box.blend --python tools/screenshots.py -- OUT_DIR

Loads the add-on from addon/ (its engine from build/engine), bakes the open file at the default
preset, opens the Radiosity tab of the 3D viewport's sidebar and shows the `Radiosity` attribute
(Solid shading, Color: Attribute, Lighting: Flat), then saves two PNGs into OUT_DIR:
  panel.png   the 3D viewport's right part: the camera's view and the sidebar's Radiosity panel
  baked.png   the camera's frame of the viewport: the baked attribute, nothing drawn over it
Each step runs from a timer so that the window has drawn what the previous step changed.
"""
import os
import sys
import tempfile

import bpy
import numpy as np
from bpy_extras.view3d_utils import location_3d_to_region_2d

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else os.path.join(ROOT, "docs", "images")
sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
from conftest import load_package  # noqa: E402  (the add-on from addon/, its engine from build/engine)

DRAW_WAIT = 1.5   # seconds between steps: Blender draws the window in between
TAB_STEPS = 1     # Ctrl+Shift+Tab from the sidebar's first tab: the Radiosity tab, registered last


def view3d():
    """(window, area, sidebar region, main region) of the largest 3D viewport."""
    window = bpy.context.window_manager.windows[0]
    area = max((a for a in window.screen.areas if a.type == 'VIEW_3D'), key=lambda a: a.width * a.height)
    regions = {r.type: r for r in area.regions}
    return window, area, regions["UI"], regions["WINDOW"]


def show_attribute(scene, space):
    for ob in scene.objects:
        if ob.type == 'MESH' and "Radiosity" in ob.data.color_attributes:
            ob.data.color_attributes.active_color = ob.data.color_attributes["Radiosity"]
    space.shading.type = 'SOLID'
    space.shading.color_type = 'VERTEX'        # "Attribute" in the UI
    space.shading.light = 'FLAT'
    scene.view_settings.view_transform = 'Standard'


def camera_frame(scene, area, main):
    """(x, y, width, height) in window pixels of the camera's frame as the viewport shows it."""
    cam = scene.camera
    corners = [cam.matrix_world @ v for v in cam.data.view_frame(scene=scene)]
    xy = np.array([location_3d_to_region_2d(main, area.spaces.active.region_3d, c) for c in corners])
    (x0, y0), (x1, y1) = np.ceil(xy.min(0)).astype(int), np.floor(xy.max(0)).astype(int)
    return main.x + x0, main.y + y0, x1 - x0, y1 - y0


def grab(window, rect, path):
    """Save the window's pixels inside rect = (x, y, width, height) (from the bottom left) as a PNG."""
    full = os.path.join(tempfile.mkdtemp(), "window.png")
    with bpy.context.temp_override(window=window):
        bpy.ops.screen.screenshot(filepath=full)
    shot = bpy.data.images.load(full)
    w, h = shot.size
    px = np.empty(w * h * 4, np.float32)
    shot.pixels.foreach_get(px)
    bpy.data.images.remove(shot)
    x, y, cw, ch = rect
    crop = px.reshape(h, w, 4)[y:y + ch, x:x + cw]
    out = bpy.data.images.new(os.path.basename(path), crop.shape[1], crop.shape[0])
    out.pixels.foreach_set(np.ascontiguousarray(crop).ravel())
    out.filepath_raw = path
    out.file_format = 'PNG'
    out.save()
    bpy.data.images.remove(out)
    print("wrote", path, f"{crop.shape[1]} x {crop.shape[0]}", flush=True)


def centre_camera():
    """Fits the camera's frame to the 3D view as it is now; returns view3d()."""
    window, area, sidebar, main = view3d()
    with bpy.context.temp_override(window=window, area=area, region=main):
        bpy.ops.view3d.view_center_camera()
    return window, area, sidebar, main


def steps():
    """The screenshot session as a generator: each yield lets Blender draw for DRAW_WAIT seconds."""
    pkg = load_package()
    pkg.register()
    scene = bpy.context.scene
    scene.radiosity.preset = 'DEFAULT'
    assert bpy.ops.radiosity.bake() == {'FINISHED'}, "bake failed"
    print(f"baked in {scene.radiosity.last_seconds:.2f} s, residual {scene.radiosity.last_residual:.1e}", flush=True)

    window, area, sidebar, main = view3d()
    space = area.spaces.active
    show_attribute(scene, space)
    space.region_3d.view_perspective = 'CAMERA'
    space.overlay.show_overlays = False
    space.show_region_toolbar = False
    space.show_region_ui = True
    yield
    window, area, sidebar, main = centre_camera()
    # Blender 3.4 gives Python no way to pick a sidebar tab: cycle to it as a user would (Ctrl+Tab),
    # with the mouse over the first panel's header (the sidebar's empty part passes events through
    # to the viewport).
    x, y = sidebar.x + sidebar.width // 2, sidebar.y + sidebar.height - 20
    window.event_simulate('MOUSEMOVE', 'NOTHING', x=x, y=y)
    for _ in range(TAB_STEPS):
        window.event_simulate('TAB', 'PRESS', x=x, y=y, ctrl=True, shift=True)
        window.event_simulate('TAB', 'RELEASE', x=x, y=y, ctrl=True, shift=True)
    yield
    window, area, sidebar, main = view3d()
    left = camera_frame(scene, area, main)[0] - 40
    grab(window, (left, area.y, area.x + area.width - left, area.height), os.path.join(OUT, "panel.png"))

    space.show_region_ui = False
    space.show_gizmo = False
    yield
    window, area, sidebar, main = centre_camera()
    yield
    window, area, sidebar, main = view3d()
    grab(window, camera_frame(scene, area, main), os.path.join(OUT, "baked.png"))
    bpy.ops.wm.quit_blender()


def run(session=steps()):
    try:
        next(session)
    except StopIteration:
        return None
    except Exception:                           # a failed step must not leave Blender open
        import traceback
        traceback.print_exc()
        os._exit(1)
    return DRAW_WAIT


os.makedirs(OUT, exist_ok=True)
bpy.app.timers.register(run, first_interval=DRAW_WAIT)
