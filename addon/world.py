"""What a world's Environment Texture sends, as the engine can take it: the image's suns as sun
lamps, and the rest as the engine's world map (Solver.set_world_map), in the world's directions."""
import numpy as np

from . import texture

__all__ = ["sky_lights", "environment_turn", "turned_about_z"]


# A texel of an environment brighter than this many times its mean over the sphere belongs to a sun.
SUN_CONTRAST = 50.0
SUN_TEXELS = 20000   # more than this many: no sun, but a bright sky


# The sky without its suns goes to the engine at most this many texels wide (and half as high): its
# light varies slowly, and the engine reads it at every ray to the sky.
SKY_MAP_WIDTH = 128


def sky_lights(node, images):
    """What an Environment Texture node's image sends, as the engine can take it: (its mean radiance
    over the sphere without its suns (3,), the same by direction (H, W, 3) or None, [(direction
    towards a sun (3,), its irradiance (3,), angular diameter)]). The suns are the texels brighter
    than SUN_CONTRAST times the image's mean, in connected patches; the rest goes in blocks of
    texels averaged by solid angle, SKY_MAP_WIDTH across at most (an equirectangular image's: a
    mirror ball's is its mean, with no suns). Over every texel: a sun a few texels wide can carry
    most of an HDRI's light."""
    image = node.image

    def work():
        px = images.pixels(image)[:, :, :3]
        if not px.size:
            return np.zeros(3), None, []
        if texture.encoded_srgb(image):
            px = texture.srgb_to_linear(px)
        if node.projection != 'EQUIRECTANGULAR':
            return px.reshape(-1, 3).mean(0, dtype=np.float64), None, []
        h, w = px.shape[:2]
        latitude = ((np.arange(h) + 0.5) / h - 0.5) * np.pi
        row_solid = (2 * np.pi / w) * (np.pi / h) * np.cos(latitude)   # a texel's solid angle, by row
        luminance = px @ np.array([0.2126, 0.7152, 0.0722], np.float32)
        mean = (luminance.sum(1, dtype=np.float64) * row_solid).sum() / (row_solid.sum() * w)
        bright = luminance > SUN_CONTRAST * mean
        # Sums by blocks of texels, in float32 but for the rows' weights: an 8k image in float64 is
        # 0.8 GB a copy. The suns' texels come off afterwards: they are few.
        step = max(1, -(-w // SKY_MAP_WIDTH))
        rows, cols = np.arange(0, h, step), np.arange(0, w, step)
        by_row = np.add.reduceat(px, cols, 1).astype(np.float64) * row_solid[:, None, None]
        blocks = np.add.reduceat(by_row, rows, 0)
        weights = np.add.reduceat(np.repeat(row_solid[:, None], len(cols), 1) *
                                  np.diff(np.append(cols, w))[None, :], rows, 0)
        suns = []
        if bright.sum() <= SUN_TEXELS:
            longitude = (0.5 - (np.arange(w) + 0.5) / w) * 2 * np.pi   # Cycles' equirectangular u
            for r, c in _patches(bright):
                lat, lon = latitude[r], longitude[c]
                towards = np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], 1)
                d = row_solid[r]
                centre = (towards * (luminance[r, c] * d)[:, None]).sum(0)
                light = px[r, c].astype(np.float64) * d[:, None]
                np.subtract.at(blocks, (r // step, c // step), light)
                suns.append((centre / np.linalg.norm(centre), light.sum(0), 2.0 * np.sqrt(d.sum() / np.pi)))
        return blocks.sum((0, 1)) / weights.sum(), blocks / weights[:, :, None], suns
    return images.sampled(image, ("sky", node.projection), None, work)


def _patches(mask):
    """[(rows, cols)] of each 8-connected patch of True in `mask`, the columns wrapping round (an
    equirectangular image's left and right edges meet)."""
    h, w = mask.shape
    label = np.zeros(mask.shape, np.int32)
    patches = []
    for start in zip(*np.nonzero(mask)):
        if label[start]:
            continue
        label[start] = len(patches) + 1
        todo, members = [start], []
        while todo:
            r, c = todo.pop()
            members.append((r, c))
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, (c + dc) % w
                    if 0 <= rr < h and mask[rr, cc] and not label[rr, cc]:
                        label[rr, cc] = label[start]
                        todo.append((rr, cc))
        patches.append(tuple(np.array(x) for x in zip(*members)))
    return patches


def environment_turn(node, warnings):
    """(3, 3) from the directions an Environment Texture's image is laid out in to the world's: the
    inverse of a Mapping node's on its Vector (its rotation and scale; directions have no place)."""
    vector = node.inputs["Vector"]
    if not vector.is_linked:
        return np.eye(3)
    source = vector.links[0].from_node
    mapping = texture.mapping_of(source, warnings) if source.type == 'MAPPING' else None
    if source.type == 'MAPPING' and mapping is None:
        return np.eye(3)   # mapping_of said why
    inner = source.inputs["Vector"].links[0] if mapping is not None and source.inputs["Vector"].is_linked else None
    if inner is None or inner.from_node.type != 'TEX_COORD' or inner.from_socket.identifier != 'Generated':
        warnings.append(f"{node.name}: directions from a {source.type} node are not followed (a Mapping "
                        "node's, from a Texture Coordinate's Generated, are)")
        return np.eye(3)
    return np.linalg.pinv(mapping[:, :3])   # a zero scale: pinv rather than a crash


def turned_about_z(sky, turn):
    """The world map `sky` (H, W, 3) laid out in the image's directions, in the world's when `turn`
    is a turn about z (by shifting its columns, interpolated); None when it is another."""
    if not (np.allclose(turn[2], (0, 0, 1)) and np.allclose(turn[:2, 2], 0)
            and np.allclose(turn[:2, :2] @ turn[:2, :2].T, np.eye(2)) and np.linalg.det(turn[:2, :2]) > 0):
        return None
    # A world direction of longitude a reads the image at a - angle: u = 0.5 - longitude / 2 pi.
    shift = np.arctan2(turn[1, 0], turn[0, 0]) / (2 * np.pi) * sky.shape[1]
    whole = int(np.floor(shift))
    part = shift - whole
    return (1 - part) * np.roll(sky, -whole, axis=1) + part * np.roll(sky, -whole - 1, axis=1)
