"""The bake's report names what light through glass and off mirrors cost the solve: the pane
crossings its rays made and the share of its rays that crossed a pane, the rays by way of mirrors
and their share, counted by the engine; a scene without panes or mirrors has no such rows and
counts nothing."""
import json
import os
import re
import sys

import bpy
import pytest

from conftest import ROOT

sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
import optics_references  # noqa: E402  (blacken: a material as a black Diffuse BSDF)

COST = re.compile(r"(?P<count>[\d,.]+)(?P<mega> M)? pane crossings, (?P<share>[\d.]+)% of the rays")


def bake_draft(scene):
    scene.radiosity.preset = 'DRAFT'
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    return {row[1]: row for row in json.loads(scene.radiosity.last_effect_items)}


def costed_row(rows, short, pattern):
    """The row whose short words begin with `short`: its short words, kind, detail and cost, and the
    count and share (of the solve's rays) its cost text gives, read with `pattern`."""
    (name, (kind, _, detail, cost)), = [(s, r) for s, r in rows.items() if s.startswith(short)]
    found = pattern.fullmatch(cost)
    assert found, cost
    count = float(found["count"].replace(",", "")) * (1e6 if found["mega"] else 1)
    return name, kind, detail, cost, count, float(found["share"]) / 100


def test_the_report_names_what_light_through_the_pane_cost(addon, open_sample):
    # The sun reaches the window room's inside through its pane alone: rays that carry it cross the pane.
    rows = bake_draft(open_sample("window_room"))
    _, kind, detail, cost, crossings, share = costed_row(rows, "Transmission", COST)
    assert kind == addon.effects.SIMULATED
    rays = bpy.context.scene.radiosity.last_rays
    # Each ray that crossed crossed once or more (the figures as rounded for the report), and some of
    # the solve's rays did, not all.
    assert crossings + (0.05e6 if crossings >= 1e5 else 0) >= rays * share * 0.95
    assert 0 < share < 1
    assert all(c == "" for short, (_, _, _, c) in rows.items() if short != "Transmission")
    assert f"{detail} [cost: {cost}]" in bpy.context.scene.radiosity.last_effects


def test_a_scene_without_panes_has_no_transmission_cost(addon, open_sample):
    scene = open_sample("window_room")
    optics_references.blacken(bpy.data.materials["Pane"])   # the pane an opaque black one
    rows = bake_draft(scene)
    assert "Transmission" not in rows
    assert all(cost == "" for _, _, _, cost in rows.values())
    assert "cost:" not in scene.radiosity.last_effects


MIRROR_COST = re.compile(r"(?P<count>[\d,.]+)(?P<mega> M)? rays by way of mirrors, (?P<share>[\d.]+)% of the rays")


def test_the_report_names_what_the_mirror_cost(addon, open_sample):
    rows = bake_draft(open_sample("mirror_room"))
    short, kind, _, _, legs, share = costed_row(rows, "Mirrors", MIRROR_COST)
    assert kind == addon.effects.SIMULATED
    # Two legs a path, all counted among the solve's rays; the lamp under the ceiling and the room's
    # walls send the mirror some of their light, not all of it.
    assert legs == pytest.approx(bpy.context.scene.radiosity.last_rays * share, rel=0.06)
    assert 0 < share < 1
    assert all(c == "" for s, (_, _, _, c) in rows.items() if s != short)
    optics_references.blacken(bpy.data.materials["Mirror"])
    rows = bake_draft(bpy.context.scene)
    assert not any(s.startswith("Mirrors") for s in rows)
    assert all(c == "" for _, _, _, c in rows.values())
