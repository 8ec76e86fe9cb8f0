"""Render DejaVu Sans (matplotlib's copy) into translucent_addon/core/report/chart_font.npz: the bitmap font that
raster_chart.py writes chart text with, so the extension needs no font library. Dev only; run once, commit
the .npz. Needs matplotlib (for its fonts) and Pillow (which matplotlib installs)."""
from __future__ import annotations

import shutil
import sys
from pathlib import Path

import matplotlib
import numpy as np
from PIL import Image, ImageDraw, ImageFont

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "translucent_addon" / "core" / "report" / "chart_font.npz"
LICENCE = ROOT / "translucent_addon" / "core" / "report" / "chart_font_LICENSE.txt"
# Pixels per em in the atlas: raster_chart draws at 2x and halves, so 24 px here is 12 px text on the chart.
SIZE = 24
CODES = range(32, 127)  # printable ASCII


def main() -> int:
    fonts = Path(matplotlib.get_data_path()) / "fonts" / "ttf"
    font = ImageFont.truetype(str(fonts / "DejaVuSans.ttf"), SIZE)
    ascent, descent = font.getmetrics()
    glyphs, left, top, advance = [], [], [], []
    for code in CODES:
        ch = chr(code)
        x0, y0, x1, y1 = font.getbbox(ch, anchor="ls")  # relative to the pen on the baseline
        if x1 <= x0 or y1 <= y0:  # the space
            x0, y0, x1, y1 = 0, 0, 0, 0
        tile = Image.new("L", (max(x1 - x0, 0), max(y1 - y0, 0)))
        if tile.width and tile.height:
            ImageDraw.Draw(tile).text((-x0, -y0), ch, font=font, fill=255, anchor="ls")
        glyphs.append(np.asarray(tile, np.uint8).reshape(y1 - y0, x1 - x0))
        left.append(x0)
        top.append(y0)
        advance.append(font.getlength(ch))
    height = max(g.shape[0] for g in glyphs)
    xs = np.cumsum([0] + [g.shape[1] + 1 for g in glyphs])  # a blank column between glyphs
    atlas = np.zeros((height, int(xs[-1])), np.uint8)
    for g, x in zip(glyphs, xs):
        atlas[:g.shape[0], x:x + g.shape[1]] = g
    np.savez_compressed(
        OUT, atlas=atlas, x=xs[:-1].astype(np.int32), width=np.array([g.shape[1] for g in glyphs], np.int32),
        height=np.array([g.shape[0] for g in glyphs], np.int32), left=np.array(left, np.int32),
        top=np.array(top, np.int32), advance=np.array(advance, np.float32), first=np.int32(CODES[0]),
        size=np.int32(SIZE), ascent=np.int32(ascent), descent=np.int32(descent))
    shutil.copyfile(fonts / "LICENSE_DEJAVU", LICENCE)
    print(f"wrote {OUT} ({OUT.stat().st_size} bytes, atlas {atlas.shape}) and {LICENCE.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
