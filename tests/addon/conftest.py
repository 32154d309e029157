import importlib.util
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SAMPLES = os.path.join(ROOT, "sample_blends")


@pytest.fixture(scope="session")
def export():
    return load_package().export


@pytest.fixture
def open_sample():
    import bpy

    def _open(name, frame=None):
        bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, name + ".blend"))
        if frame is not None:
            bpy.context.scene.frame_set(frame)
        return bpy.context.scene
    return _open


def load_engine():
    """The engine module as the add-on loads it (next to the add-on, else build/engine). Test files
    that need it call this when pytest collects them: a missing or broken engine then stops the run
    with an error that names it, where a skip would let a broken build pass."""
    return load_package().engine.load_engine()


def load_package():
    """The add-on package from the source tree (addon/) as `dynamic_radiosity`; its engine falls
    back to build/engine."""
    if "dynamic_radiosity" in sys.modules and getattr(sys.modules["dynamic_radiosity"], "_from_tests", False):
        return sys.modules["dynamic_radiosity"]
    for k in [k for k in sys.modules if k == "dynamic_radiosity" or k.startswith("dynamic_radiosity.")]:
        del sys.modules[k]
    spec = importlib.util.spec_from_file_location(
        "dynamic_radiosity", os.path.join(ROOT, "addon", "__init__.py"),
        submodule_search_locations=[os.path.join(ROOT, "addon")])
    pkg = importlib.util.module_from_spec(spec)
    sys.modules["dynamic_radiosity"] = pkg
    spec.loader.exec_module(pkg)
    pkg._from_tests = True
    pkg.__addon_enabled__ = False            # silences addon_utils' name-collision warning
    return pkg


@pytest.fixture(scope="session")
def addon():
    pkg = load_package()
    pkg.register()
    yield pkg
    pkg.unregister()
