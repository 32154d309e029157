"""A tiny log-log plotter without matplotlib: numpy raster, 5x7 bitmap font, PNG via zlib + struct.

    c = Canvas(800, 500)
    ax = LogAxes(c, (60, 30, 380, 300), (0.1, 100), (0.001, 1), "seconds", "error")
    ax.frame(xticks=[0.1, 1, 10, 100], yticks=[0.001, 0.01, 0.1, 1], fmt_y=lambda v: f"{v:.1%}")
    ax.polyline([(0.2, 0.1), (2, 0.01)], BLUE, marker="o", labels=["a", "b"])
    c.save("plot.png")
"""
import struct
import zlib

import numpy as np

# 5x7 glyphs: 7 rows of 5 bits (MSB = left column), two hex digits per row. Lower case draws as upper.
FONT = {
    "0": "0E11131519110E", "1": "040C040404040E", "2": "0E11010204081F", "3": "1F02040201110E",
    "4": "02060A121F0202", "5": "1F101E0101110E", "6": "0608101E11110E", "7": "1F010204080808",
    "8": "0E11110E11110E", "9": "0E11110F01020C", "A": "0E11111F111111", "B": "1E11111E11111E",
    "C": "0E11101010110E", "D": "1C12111111121C", "E": "1F10101E10101F", "F": "1F10101E101010",
    "G": "0E11101711110F", "H": "1111111F111111", "I": "0E04040404040E", "J": "0702020202120C",
    "K": "11121418141211", "L": "1010101010101F", "M": "111B1515111111", "N": "11111915131111",
    "O": "0E11111111110E", "P": "1E11111E101010", "Q": "0E11111115120D", "R": "1E11111E141211",
    "S": "0F10100E01011E", "T": "1F040404040404", "U": "1111111111110E", "V": "11111111110A04",
    "W": "1111111515150A", "X": "11110A040A1111", "Y": "1111110A040404", "Z": "1F01020408101F",
    " ": "00000000000000", ".": "00000000000C0C", ",": "000000000C0408", "%": "18190204081303",
    "(": "02040808080402", ")": "08040202020408", "-": "0000001F000000", "+": "0004041F040400",
    ":": "000C0C000C0C00", "/": "00010204081000", "=": "00001F001F0000", "_": "0000000000001F",
    "@": "0E11010D15150E", "<": "02040810080402", ">": "08040201020408", "'": "04040800000000",
    "*": "0004150E150400",
}


def glyph(ch):
    rows = FONT.get(ch.upper(), FONT["*"])
    bits = [int(rows[i:i + 2], 16) for i in range(0, 14, 2)]
    return np.array([[(b >> (4 - k)) & 1 for k in range(5)] for b in bits], bool)


class Canvas:
    def __init__(self, width, height, background=(255, 255, 255)):
        self.img = np.empty((height, width, 3), np.uint8)
        self.img[:] = background
        self.h, self.w = height, width

    def _stamp(self, mask, x, y, color):
        """Paint a boolean mask with its top-left at (x, y), clipped to the canvas."""
        h, w = mask.shape
        x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, self.w), min(y + h, self.h)
        if x0 < x1 and y0 < y1:
            self.img[y0:y1, x0:x1][mask[y0 - y:y1 - y, x0 - x:x1 - x]] = color

    def dot(self, x, y, r, color, shape="o"):
        """Filled marker of radius r: o disc, s square, ^ triangle, d diamond."""
        n = int(np.ceil(r))
        yy, xx = np.mgrid[-n:n + 1, -n:n + 1] + 0.0
        mask = {"o": xx ** 2 + yy ** 2 <= r * r,
                "s": (abs(xx) <= r * 0.85) & (abs(yy) <= r * 0.85),
                "d": abs(xx) + abs(yy) <= r * 1.2,
                "^": (yy <= r * 0.8) & (abs(xx) * 2 <= (yy + r) * 1.1)}[shape]
        self._stamp(mask, int(round(x)) - n, int(round(y)) - n, color)

    def line(self, x0, y0, x1, y1, color, width=1.0, dash=0):
        """Segment stamped with discs every half pixel; dash > 0 draws dash-px on, dash-px off."""
        length = max(np.hypot(x1 - x0, y1 - y0), 1e-9)
        t = np.arange(0, length + 0.5, 0.5)
        if dash:
            t = t[(t // dash) % 2 == 0]
        for s in t:
            f = s / length
            self.dot(x0 + f * (x1 - x0), y0 + f * (y1 - y0), width / 2, color)

    def rect(self, x0, y0, x1, y1, color):
        self.img[max(y0, 0):max(y1, 0), max(x0, 0):max(x1, 0)] = color

    def text(self, x, y, s, color=(0, 0, 0), scale=2, anchor="l", vertical=False):
        """Text with its left/centre/right (anchor l/c/r) at x and its top at y; vertical reads upward."""
        mask = np.zeros((7, 6 * len(s)), bool)
        for i, ch in enumerate(s):
            mask[:, 6 * i:6 * i + 5] = glyph(ch)
        mask = mask[:, :-1].repeat(scale, 0).repeat(scale, 1)
        if vertical:
            mask = np.rot90(mask)
            h = mask.shape[0]
            y = y - {"l": -h, "c": -h // 2, "r": 0}[anchor] - h
        else:
            x = x - {"l": 0, "c": mask.shape[1] // 2, "r": mask.shape[1]}[anchor]
        self._stamp(mask, int(x), int(y), color)

    def save(self, path):
        write_png(path, self.img)


def write_png(path, rgb):
    """8-bit RGB PNG: signature, IHDR, one IDAT (filter 2, "up", on every row: each byte less the one
    above it, which smooth pictures leave near zero and zlib packs well), IEND."""
    h, w, _ = rgb.shape
    rows = rgb.reshape(h, w * 3).astype(np.uint8)
    up = rows - np.vstack([np.zeros((1, w * 3), np.uint8), rows[:-1]])   # wraps mod 256, as PNG's filter does
    raw = np.hstack([np.full((h, 1), 2, np.uint8), up]).tobytes()

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


class LogAxes:
    """A log-log panel in the pixel box (left, top, right, bottom) of a Canvas."""

    def __init__(self, canvas, box, xlim, ylim, xlabel="", ylabel="", title=""):
        self.c, self.box, self.xlim, self.ylim = canvas, box, xlim, ylim
        self.xlabel, self.ylabel, self.title = xlabel, ylabel, title

    def to_px(self, x, y):
        l, t, r, b = self.box
        fx = (np.log10(x) - np.log10(self.xlim[0])) / (np.log10(self.xlim[1]) - np.log10(self.xlim[0]))
        fy = (np.log10(y) - np.log10(self.ylim[0])) / (np.log10(self.ylim[1]) - np.log10(self.ylim[0]))
        return l + fx * (r - l), b - fy * (b - t)

    def frame(self, xticks, yticks, fmt_x=lambda v: f"{v:g}", fmt_y=lambda v: f"{v:g}", ylabels=True):
        c, (l, t, r, b) = self.c, self.box
        grey, dark = (225, 225, 225), (60, 60, 60)
        for v in xticks:
            x, _ = self.to_px(v, self.ylim[0])
            c.line(x, t, x, b, grey)
            c.line(x, b, x, b + 5, dark)
            c.text(x, b + 9, fmt_x(v), dark, 2, "c")
        for v in yticks:
            _, y = self.to_px(self.xlim[0], v)
            c.line(l, y, r, y, grey)
            c.line(l - 5, y, l, y, dark)
            if ylabels:
                c.text(l - 9, y - 7, fmt_y(v), dark, 2, "r")
        for x0, y0, x1, y1 in ((l, t, r, t), (l, b, r, b), (l, t, l, b), (r, t, r, b)):
            c.line(x0, y0, x1, y1, dark, 1.5)
        c.text((l + r) / 2, b + 30, self.xlabel, (0, 0, 0), 2, "c")
        c.text((l + r) / 2, t - 22, self.title, (0, 0, 0), 2, "c")
        if self.ylabel:
            c.text(l - 78, (t + b) / 2, self.ylabel, (0, 0, 0), 2, "c", vertical=True)

    def polyline(self, points, color, marker="o", width=2.0, dash=0, labels=None, label_side="r"):
        """Points (x, y) joined in order, each with a marker and an optional small label."""
        px = [self.to_px(x, y) for x, y in points]
        for (x0, y0), (x1, y1) in zip(px, px[1:]):
            self.c.line(x0, y0, x1, y1, color, width, dash)
        for i, (x, y) in enumerate(px):
            self.c.dot(x, y, 5, color, marker)
            if labels and labels[i]:
                if label_side == "r":
                    self.c.text(x + 8, y - 3, labels[i], color, 1)
                else:
                    self.c.text(x - 8, y - 3, labels[i], color, 1, "r")

    def hline(self, y, color, label=""):
        (l, t, r, b) = self.box
        _, py = self.to_px(self.xlim[0], y)
        self.c.line(l, py, r, py, color, 1.5, dash=6)
        if label:
            self.c.text(r - 4, py - 12, label, color, 1, "r")
