"""Finding and loading the engine module, radiosity_engine."""
import os
import sys

from .errors import BakeError


def load_engine():
    """The radiosity_engine module: bundled next to the add-on, else the source tree's build/engine.
    Missing or broken (it does not import), a BakeError that names it and says why."""
    try:
        from . import radiosity_engine
        return radiosity_engine
    except ImportError:
        pass
    if "radiosity_engine" in sys.modules:
        return sys.modules["radiosity_engine"]
    here = os.path.dirname(os.path.abspath(__file__))
    build = os.path.join(os.path.dirname(here), "build", "engine")
    if os.path.isdir(build) and build not in sys.path:
        sys.path.append(build)
    try:
        import radiosity_engine
    except ImportError as e:
        raise BakeError(f"the radiosity engine module is missing or broken ({e}): re-install the add-on") from e
    return radiosity_engine
