"""A missing or broken engine fails both test suites, with a message naming it: a suite that skipped
the tests needing it would pass under ./test.sh on a broken build.

Each suite runs as test.sh runs it, on a copy of the source tree with no build/ (the engine module
nowhere to be found), or with a file in the module's place that does not load."""
import importlib.machinery
import os
import shutil
import subprocess

import bpy
import pytest

from conftest import ROOT

PYTHON = "/usr/bin/python3.11"    # what ctest runs the engine's Python tests with (tests/CMakeLists.txt)
HERE = os.path.basename(__file__)


def tree(tmp_path, engine):
    """The add-on and the tests copied under tmp_path; `engine`: "missing" (no build/) or "broken"."""
    root = tmp_path / "tree"
    shutil.copytree(os.path.join(ROOT, "addon"), root / "addon",
                    ignore=shutil.ignore_patterns("__pycache__", "radiosity_engine*"))
    shutil.copytree(os.path.join(ROOT, "tests"), root / "tests", ignore=shutil.ignore_patterns("__pycache__", "*.npz"))
    if engine == "broken":
        build = root / "build" / "engine"
        build.mkdir(parents=True)
        (build / ("radiosity_engine" + importlib.machinery.EXTENSION_SUFFIXES[0])).write_bytes(b"not a library")
    return root


def run(command):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}   # nothing else may supply the engine
    done = subprocess.run(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=300)
    return done.returncode, done.stdout


@pytest.mark.parametrize("engine", ["missing", "broken"])
def test_the_suites_fail_without_a_working_engine(tmp_path, engine):
    root = tree(tmp_path, engine)
    addon_tests = root / "tests" / "addon"
    rc, out = run([bpy.app.binary_path, "-b", "--factory-startup", "--python-exit-code", "1",
                   "--python", str(addon_tests / "run_pytest.py"), "--", str(addon_tests), "-q",
                   f"--ignore={addon_tests / HERE}"])     # not this test again, inside itself
    assert rc != 0, out
    assert "radiosity engine module is missing or broken" in out and "radiosity_engine" in out, out
    rc, out = run([PYTHON, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(root / "tests" / "engine")])
    assert rc != 0, out
    assert "the engine module radiosity_engine is missing or broken" in out, out
