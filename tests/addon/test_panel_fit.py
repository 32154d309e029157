"""Every text the Radiosity panels draw fits, uncut, in a default-width 3D View sidebar and in the
Properties editor, at Blender's default UI scale.

Background Blender has no regions to draw into, so each panel's draw() runs on a recording stand-in
for UILayout that lays its items out as Blender 3.4's layout engine does (interface_layout.c) and
measures each text with blf at the UI font's size. Blender cuts a text out of the middle
(ui_text_clip_middle) when it is wider than the space its button leaves it; here that is a failure.

Numbers at the default UI scale (U.dpi 72, widget unit 20 px), from Blender 3.4's sources:
- the sidebar region is UI_SIDEBAR_PANEL_WIDTH = 220 px wide (space_view3d.c, prefsizex); with more
  than one tab, UI_PANEL_CATEGORY_MARGIN_WIDTH = 20 px of it holds the tabs (area.c,
  ED_region_panels_layout_ex);
- a panel leaves UI_PANEL_MARGIN_X = 8 px each side of the region, and its layout
  style->panelspace = 8 px each side inside it (area.c, interface_style.c); a box style->boxspace = 5;
- the Properties editor of the factory startup file, in tools/screenshots.sh's 1600 x 900 window,
  has a 248 px main region at the 75 dpi Xvfb reports: 238 px at 72 dpi;
- use_property_split gives the label UI_ITEM_PROP_SEP_DIVIDE = 40% of the width, the value the rest
  (interface_layout.c); a checkbox sits in the value column with its text beside it;
- text is padded UI_TEXT_MARGIN_X * widget unit = 8 px from the side it is aligned to; an icon takes
  16 + 2 px; a checkbox 0.7 * 20 + 3 = 17 px; a menu's arrow 20 px; buttons other than labels and
  menus keep UI_TEXT_CLIP_MARGIN = 5 px clear (interface_widgets.c);
- the UI font is font 0 at 11 points (UI_DEFAULT_TEXT_POINTS) at 72 dpi.
Rows split their width evenly, less 8 px (style->buttonspacex) between items unless aligned.
"""
import os
from types import SimpleNamespace

import blf
import bpy
import pytest

SAMPLES = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                       "sample_blends")

SIDEBAR_REGION, TABS, PANEL_MARGIN, PANEL_SPACE, BOX_SPACE = 220, 20, 8, 8, 5
PROPERTIES_REGION = 238
SPLIT, PAD, ICON, CHECKBOX, ARROW, CLIP, ROW_SPACE = 0.4, 8, 18, 17, 20, 5, 8
FONT_POINTS = 11

WIDTHS = {"sidebar": SIDEBAR_REGION - TABS - 2 * PANEL_MARGIN - 2 * PANEL_SPACE,
          "render": PROPERTIES_REGION - 2 * PANEL_MARGIN - 2 * PANEL_SPACE}


def text_width(text):
    blf.size(0, FONT_POINTS)                   # at 72 dpi
    return blf.dimensions(0, text)[0]


class Recorder:
    """A UILayout stand-in: keeps the items drawn into it as a tree, laid out by measure()."""

    def __init__(self, kind="column", split=False, factor=None, heading=""):
        self.kind, self.factor, self.heading = kind, factor, heading
        self.items = []
        self.use_property_split = split
        self.use_property_decorate = False
        self.active = self.enabled = self.alert = True
        self.alignment, self.scale_x, self.scale_y = 'EXPAND', 1.0, 1.0
        self.operator_context = 'INVOKE_DEFAULT'

    def _child(self, kind, align=False, heading="", factor=None):
        c = Recorder(kind, self.use_property_split, factor, heading)
        c.align = align
        self.items.append(c)
        return c

    def column(self, align=False, heading="", **_kw):
        return self._child("column", align, heading)

    def row(self, align=False, heading="", **_kw):
        return self._child("row", align, heading)

    def box(self):
        return self._child("box")

    def split(self, factor=0.0, align=False):
        return self._child("split", align, factor=factor)

    def label(self, text="", icon='NONE', **_kw):
        self.items.append(("label", text, icon != 'NONE'))

    def operator(self, idname, text=None, icon='NONE', **_kw):
        if text is None:
            module, name = idname.split(".")
            text = getattr(getattr(bpy.ops, module), name).get_rna_type().name
        self.items.append(("button", text, icon != 'NONE'))
        return SimpleNamespace()

    def menu(self, _menu, text="", icon='NONE', **_kw):
        self.items.append(("menu", text, icon != 'NONE'))

    def prop(self, data, name, text=None, icon='NONE', **_kw):
        self.items.append(("prop", data, name, text, icon != 'NONE', self.use_property_split))

    def separator(self, **_kw):
        pass

    def measure(self, width, where, cut):
        """Lays the items out in `width` px; appends to `cut` each text that would not fit."""
        if self.kind == "box":
            width -= 2 * BOX_SPACE
        if self.heading and self.use_property_split:
            fits(self.heading, SPLIT * width - PAD, where, cut)
        n = len(self.items)
        for i, item in enumerate(self.items):
            w = width
            if self.kind == "row" and n > 1:
                w = (width - (0 if self.align else ROW_SPACE * (n - 1))) / n
            elif self.kind == "split":
                f = self.factor or 1.0 / n
                w = width * (f if i == 0 else (1 - f) / max(n - 1, 1))
            if isinstance(item, Recorder):
                item.measure(w, where, cut)
            else:
                leaf(item, w, where, cut)


def fits(text, room, where, cut):
    need = text_width(text)
    if text and need > room:
        cut.append(f"{where}: '{text}' needs {need:.0f} px, has {room:.0f}")


def leaf(item, w, where, cut):
    kind = item[0]
    if kind == "label":
        _, text, icon = item
        fits(text, w - PAD - (ICON if icon else 0), where, cut)
    elif kind == "button":
        _, text, icon = item
        fits(text, w - PAD - CLIP - (ICON if icon else 0), where, cut)
    elif kind == "menu":
        _, text, icon = item
        fits(text, w - PAD - ARROW - (ICON if icon else 0), where, cut)
    else:
        _, data, name, text, icon, split = item
        p = data.bl_rna.properties[name]
        text = p.name if text is None else text
        if p.type == 'BOOLEAN':
            fits(text, (1 - SPLIT if split else 1) * w - CHECKBOX - PAD - CLIP, where, cut)
        elif split:
            fits(text, SPLIT * w - PAD, where, cut)
            if p.type == 'ENUM':
                for e in p.enum_items:
                    fits(e.name, (1 - SPLIT) * w - PAD - ARROW, where, cut)
        elif p.type == 'ENUM':
            fits(getattr(data, name) and p.enum_items[getattr(data, name)].name, w - PAD - ARROW, where, cut)
        elif text:
            value = getattr(data, name)
            shown = f"{value:.{p.precision}f}" if p.type == 'FLOAT' else str(value)
            fits(f"{text}: {shown}", w - 2 * PAD - CLIP, where, cut)


def draw_all(addon, cut):
    for cls in addon.panels.classes:
        if not issubclass(cls, bpy.types.Panel):
            continue
        place = "sidebar" if cls.bl_space_type == 'VIEW_3D' else "render"
        width = WIDTHS[place]
        fits(cls.bl_label, width - 2 * ARROW, f"{place} {cls.bl_label} header", cut)
        layout = Recorder()
        cls.draw(SimpleNamespace(layout=layout), bpy.context)
        layout.measure(width, f"{place} {cls.bl_label}", cut)
        if hasattr(cls, "draw_header"):        # beside the header's title
            layout = Recorder()
            cls.draw_header(SimpleNamespace(layout=layout), bpy.context)
            layout.measure(width - 2 * ARROW - text_width(cls.bl_label), f"{place} {cls.bl_label} header", cut)


@pytest.fixture
def baked(addon):
    """The Cornell box after a Draft bake, with every optional part of the panels shown."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, "cornell_box.blend"))
    scene = bpy.context.scene
    props = scene.radiosity
    props.preset = 'DRAFT'
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    props.lightmaps = props.show_bake = props.live_update = True
    props.auto_relaxation = False
    props.last_warnings = "\n".join(["the solve stopped before reaching the threshold"] * 2)
    return scene


LIVE = [dict(mode="incremental", seconds_total=1.27, points=9000, touched_points=900, residual=0.012,
             budgeted=True, restart=None, settled=False),
        dict(mode="incremental", seconds_total=0.034, points=9000, touched_points=8990, residual=0.0004,
             budgeted=False, restart=None, settled=False),
        dict(mode="incremental", seconds_total=0.5, points=9000, touched_points=9000, residual=0.0,
             budgeted=False, restart="the light grew", settled=True),
        dict(mode="full", seconds_total=12.5, points=9000, residual=0.001, reason="no solver for this scene yet"),
        dict(mode="unchanged"),
        dict(mode="error", reason="the solve did not finish")]


def test_every_text_of_the_panels_fits(addon, baked):
    scene = baked
    cut = []
    draw_all(addon, cut)
    addon.farm.progress[scene.name] = (120, 250)
    try:
        for info in LIVE:
            addon.live_update.last_sync[scene.name] = info
            draw_all(addon, cut)
    finally:
        addon.farm.progress.pop(scene.name, None)
        addon.live_update.last_sync.pop(scene.name, None)
    scene.radiosity.has_results = False
    draw_all(addon, cut)
    assert not cut, "cut in a default-width sidebar or Properties editor:\n" + "\n".join(sorted(set(cut)))


def test_the_recorder_sees_a_cut():
    """The measure itself: a text as wide as the sidebar cannot fit in it, a short one does."""
    cut = []
    layout = Recorder()
    layout.label(text="Radiosity")
    layout.label(text="W" * 40)
    layout.measure(WIDTHS["sidebar"], "test", cut)
    assert len(cut) == 1 and "WWW" in cut[0]
    assert 0 < text_width("Radiosity") < WIDTHS["sidebar"] / 2


def labels_of(layout):
    out = []
    for item in layout.items:
        out += labels_of(item) if isinstance(item, Recorder) else [item[1]] if item[0] == "label" else []
    return out


def test_last_bake_shows_a_live_update_made_without_a_bake(addon):
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, "cornell_box.blend"))
    scene = bpy.context.scene
    addon.live_update.last_sync[scene.name] = dict(LIVE[3], converged=True, residual=0.001)
    try:
        layout = Recorder()
        addon.panels.draw_results(layout, bpy.context)
    finally:
        addon.live_update.last_sync.pop(scene.name, None)
    assert labels_of(layout) == ["Live update, 12 s", "Converged (0.1% light left)"]


def test_the_quality_menu_gives_each_presets_time(addon):
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, "cornell_box.blend"))
    shown = []
    layout = SimpleNamespace(prop_enum=lambda _data, _name, value, text: shown.append((value, text)))
    addon.panels.RADIOSITY_MT_quality.draw(SimpleNamespace(layout=layout), bpy.context)
    assert [v for v, _ in shown] == ['DRAFT', 'DEFAULT', 'HIGH', 'REFERENCE']
    assert all(t.split()[0] in ("Draft", "Default", "High", "Reference") and t.endswith((" s", " min", " h"))
               for _, t in shown), shown
