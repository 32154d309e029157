"""BakeError: why a bake cannot start or go on, in the words the user reads in its report."""


class BakeError(Exception):
    """A user-facing error: the bake cannot start (message says why and which object)."""
