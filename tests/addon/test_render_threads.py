"""A bake works on the threads Blender's Render > Performance > Threads gives, as Cycles does."""
import os

import bpy


def bake_threads(addon, open_sample, mode, threads=1):
    scene = open_sample("cornell_box")
    scene.radiosity.preset = 'DRAFT'
    scene.render.threads_mode = mode
    scene.render.threads = threads
    job = addon.job.BakeJob(scene, bpy.context.evaluated_depsgraph_get(), scene.radiosity)
    job.solve()
    assert job.succeeded
    return job.stats["threads"]


def test_fixed_threads_are_what_the_engine_works_on(addon, open_sample):
    assert bake_threads(addon, open_sample, 'FIXED', 1) == 1


def test_auto_detect_takes_every_core(addon, open_sample):
    assert bake_threads(addon, open_sample, 'AUTO') == os.cpu_count()
