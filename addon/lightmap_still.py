"""A still bake's lightmaps, with the interface of Bake Animation's (lightmap_sequence.SequenceBake):
prepare() and commit() on the main thread, evaluate() anywhere, so that a modal bake evaluates
them in its worker thread after the solve instead of freezing Blender. The images are written
only by commit(), once the whole bake succeeded: a failed or cancelled bake leaves them as they
were. What the evaluation learnt (each object's rasterised texels and light) goes on to live
update, whose first update then evaluates only the lightmaps whose light changed.
"""
from . import lightmap
from .lightmap_updates import Lightmaps


class StillBake:
    def __init__(self):
        self.updates = Lightmaps()
        self.messages = []
        self.pixels = {}       # {object name: (height, width, 4) rgba}, from write()
        self._plan = {}

    def prepare(self, job, props):
        self._plan, self.messages = self.updates.prepare(job, props)

    def evaluate(self, job):
        """{object name: rgba}: every lightmap of job's solve (a new Lightmaps evaluates them all)."""
        return self.updates.evaluate(job, self._plan)

    def write(self, _frame, pixels):
        self.pixels = pixels

    def commit(self):
        """The images written. Returns the messages."""
        for object_name, rgba in self.pixels.items():
            lightmap.write_image(lightmap.image_name(object_name), rgba.shape[1], rgba.shape[0], rgba)
        return self.messages

    def discard(self):
        self.pixels = {}
