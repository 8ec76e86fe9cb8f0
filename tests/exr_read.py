"""Read every channel of an uncompressed scanline OpenEXR file (what Blender writes with codec NONE), multilayer
included: the tests compare render passes (ours and Cycles') that ``bpy.data.images.load`` cannot reach.

OpenEXR file layout ("Technical Introduction to OpenEXR", the file layout chapter): magic, version, header
attributes (name, type, size, value) up to an empty name, the line offset table, then one block per scanline:
y, byte count, and each channel's values for that line, the channels in the header's (alphabetical) order.
"""
from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

MAGIC = 20000630
PIXEL_TYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}


def _cstring(data: bytes, at: int) -> tuple[str, int]:
    end = data.index(b"\0", at)
    return data[at:end].decode(), end + 1


def _header(data: bytes, at: int) -> tuple[dict, int]:
    """One header's attributes (name -> (type, bytes)) and where it ends (after its closing null)."""
    header = {}
    while True:
        name, at = _cstring(data, at)
        if not name:
            return header, at
        kind, at = _cstring(data, at)
        (size,) = struct.unpack_from("<i", data, at)
        at += 4
        header[name] = (kind, data[at:at + size])
        at += size


def _channels(header: dict) -> list[tuple[str, np.dtype]]:
    raw = header["channels"][1]
    out, i = [], 0
    while raw[i] != 0:
        name, i = _cstring(raw, i)
        (pixel_type,) = struct.unpack_from("<i", raw, i)
        i += 16  # type, pLinear + 3 reserved bytes, x and y sampling
        out.append((name, PIXEL_TYPES[pixel_type]))
    return out


def read_exr(path) -> dict[str, np.ndarray]:
    """Channel name -> (H, W) float32, row 0 at the bottom (Blender's order). Uncompressed scanline files, single- or
    multi-part (Blender 5 writes a multilayer file as one part per pass: the part's name joins its channels')."""
    data = Path(path).read_bytes()
    magic, version = struct.unpack_from("<ii", data, 0)
    if magic != MAGIC:
        raise ValueError(f"{path}: not an OpenEXR file")
    if version & 0x200:
        raise ValueError(f"{path}: tiled files are not read here")
    multipart = bool(version & 0x1000)
    at = 8
    headers = []
    while True:
        header, at = _header(data, at)
        headers.append(header)
        if not multipart or data[at] == 0:
            at += 1 if multipart else 0
            break
    parts = []
    for header in headers:
        if header["compression"][1][0] != 0:
            raise ValueError(f"{path}: compressed (write it with codec NONE)")
        x0, y0, x1, y1 = struct.unpack_from("<iiii", header["dataWindow"][1], 0)
        height = y1 - y0 + 1
        prefix = header["name"][1].rstrip(b"\0").decode() if "name" in header else ""
        parts.append((_channels(header), x1 - x0 + 1, height, y0, prefix))
    out: dict[str, np.ndarray] = {}
    for number, (channels, width, height, y0, prefix) in enumerate(parts):
        offsets = np.frombuffer(data, "<u8", height, at)
        at += 8 * height
        for name, _ in channels:
            full = name if "." in name or not prefix else f"{prefix}.{name}"
            out[full] = np.empty((height, width), np.float32)
        for offset in offsets:
            pos = int(offset)
            if multipart:
                (part,) = struct.unpack_from("<i", data, pos)
                assert part == number
                pos += 4
            y, _ = struct.unpack_from("<ii", data, pos)
            pos += 8
            row = height - 1 - (y - y0)  # EXR's first line is the top
            for name, dtype in channels:
                full = name if "." in name or not prefix else f"{prefix}.{name}"
                out[full][row] = np.frombuffer(data, dtype, width, pos).astype(np.float32)
                pos += width * dtype.itemsize
    return out
