"""Run pytest inside Blender.

    blender -b --factory-startup --python-exit-code 1 --python tests/addon/run_pytest.py -- tests/addon [pytest args]

Exits non-zero (through --python-exit-code) when any test fails.
"""
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [HERE]
rc = pytest.main(["-p", "no:cacheprovider", *argv])
if rc not in (0, pytest.ExitCode.OK):
    raise SystemExit(f"pytest failed with exit code {int(rc)}")
