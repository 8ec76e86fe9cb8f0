"""A bake's arrays as one OpenEXR image, so that Blender's file tools and a farm's packer carry them.

An image data block is the file reference Blender's own machinery follows: *Pack Resources*, *Report / Find
Missing Files*, *Make Paths Relative*, ``bpy.data.file_path_map()`` / ``bpy.utils.blend_paths()`` and the
Blender Asset Tracer (BAT 2 asks Blender for exactly those paths) all see it; a path in a custom property they
do not. So a bake file is a valid single-part scanline OpenEXR (OpenEXR file layout, "Technical Introduction"):
one FLOAT channel ``Y``, uncompressed, ``WIDTH`` values a line, whose 32-bit words are the bake's stored arrays'
bytes one after another. The words are moved, never converted (an int32 index or a float16 pair is a word like
any other), so the file is lossless by construction, and reading is one file read and one strided copy, as fast
as the ``.npz`` files it replaces. A header attribute ``translucentBake`` (JSON) names each array, its dtype,
word offset and length. Blender opens the file as a grey image if a user views it; nothing here depends on that.
"""
from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np

WIDTH = 4096  # values a scanline: 16 KiB lines, a 125 MB bake is ~7,600 of them
MAGIC = 20000630  # OpenEXR's magic number
_VERSION = 2  # file format version 2, single-part scanline, short names
_FLOAT = 2  # pixel type FLOAT
_NO_COMPRESSION = 0
ATTRIBUTE = "translucentBake"
_WORD = np.dtype("<u4")


class ExrError(ValueError):
    """Bytes that are not a bake image this module wrote (or that were cut short)."""


def _attribute(name: str, kind: str, value: bytes) -> bytes:
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


def _header(width: int, height: int, index: dict) -> bytes:
    channels = b"Y\0" + struct.pack("<iB3xii", _FLOAT, 0, 1, 1) + b"\0"
    window = struct.pack("<4i", 0, 0, width - 1, height - 1)
    return b"".join([
        struct.pack("<ii", MAGIC, _VERSION),
        _attribute("channels", "chlist", channels),
        _attribute("compression", "compression", bytes([_NO_COMPRESSION])),
        _attribute("dataWindow", "box2i", window),
        _attribute("displayWindow", "box2i", window),
        _attribute("lineOrder", "lineOrder", b"\0"),
        _attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
        _attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)),
        _attribute("screenWindowWidth", "float", struct.pack("<f", 1.0)),
        _attribute(ATTRIBUTE, "string", json.dumps(index, sort_keys=True).encode()),
        b"\0",
    ])


def encode(arrays: dict[str, np.ndarray]) -> bytes:
    """The EXR file of flat arrays whose items are 4 or 8 bytes (float32, int32, float64; float16 kept two to
    an int32 by ``bake_store``)."""
    entries, words, offset = [], [], 0
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        if a.dtype.itemsize % 4:
            raise TypeError(f"array '{name}' has {a.dtype.itemsize}-byte items; an EXR bake stores 4- or 8-byte ones")
        w = a.reshape(-1).view(_WORD)
        entries.append({"name": name, "dtype": a.dtype.str, "offset": offset, "words": int(w.size)})
        words.append(w)
        offset += int(w.size)
    height = max(1, -(-offset // WIDTH))
    header = _header(WIDTH, height, {"format": 1, "arrays": entries})
    line = 8 + 4 * WIDTH
    first = len(header) + 8 * height
    table = (first + line * np.arange(height, dtype="<u8")).astype("<u8").tobytes()
    body = np.zeros((height, line // 4), _WORD)
    body[:, 0] = np.arange(height, dtype=np.uint32)  # each chunk: its line y and its data size, then the line
    body[:, 1] = 4 * WIDTH
    flat = np.zeros(height * WIDTH, _WORD)
    if offset:
        flat[:offset] = np.concatenate(words)
    body[:, 2:] = flat.reshape(height, WIDTH)
    return header + table + body.tobytes()


def _read_header(buf: memoryview) -> tuple[dict, int]:
    """The header's attributes {name: (type, bytes)} and where the line offset table begins."""
    if len(buf) < 8 or struct.unpack_from("<i", buf, 0)[0] != MAGIC:
        raise ExrError("not an OpenEXR file")
    version = struct.unpack_from("<i", buf, 4)[0]
    if version & 0xFF != 2 or version & 0x1E00:  # tiled, long names, deep or multi-part: not ours
        raise ExrError("not a single-part scanline OpenEXR file")
    attributes, pos = {}, 8
    try:
        while buf[pos] != 0:
            name_end = bytes(buf[pos:pos + 256]).index(b"\0")
            name = bytes(buf[pos:pos + name_end]).decode()
            pos += name_end + 1
            kind_end = bytes(buf[pos:pos + 256]).index(b"\0")
            kind = bytes(buf[pos:pos + kind_end]).decode()
            pos += kind_end + 1
            size = struct.unpack_from("<i", buf, pos)[0]
            pos += 4
            if size < 0 or pos + size > len(buf):
                raise ExrError("its header is cut short")
            attributes[name] = (kind, bytes(buf[pos:pos + size]))
            pos += size
    except (IndexError, ValueError, struct.error) as err:
        raise ExrError(f"its header cannot be read ({err})") from None
    return attributes, pos + 1


def decode(data: bytes | bytearray | memoryview | np.ndarray) -> dict[str, np.ndarray]:
    """The flat arrays of a file ``encode`` wrote (its bytes), each with its stored dtype."""
    buf = memoryview(data).cast("B") if not isinstance(data, np.ndarray) else memoryview(data.reshape(-1)).cast("B")
    attributes, table_at = _read_header(buf)
    try:
        index = json.loads(attributes[ATTRIBUTE][1])
        x0, y0, x1, y1 = struct.unpack("<4i", attributes["dataWindow"][1])
        compression = attributes["compression"][1][0]
    except (KeyError, ValueError, struct.error, IndexError) as err:
        raise ExrError(f"it holds no bake ({err})") from None
    width, height = x1 - x0 + 1, y1 - y0 + 1
    line = 8 + 4 * width
    if compression != _NO_COMPRESSION or width <= 0 or height <= 0:
        raise ExrError("it is not an uncompressed bake image")
    if table_at + 8 * height > len(buf):
        raise ExrError("it is cut short")
    offsets = np.frombuffer(buf, "<u8", height, table_at)
    first = int(offsets[0])
    if first + line * height > len(buf) or np.any(offsets != first + line * np.arange(height, dtype=np.uint64)):
        raise ExrError("it is cut short, or its lines are not where its offset table says")
    lines = np.frombuffer(buf, _WORD, height * line // 4, first).reshape(height, line // 4)
    words = np.ascontiguousarray(lines[:, 2:]).reshape(-1)
    arrays = {}
    try:
        for entry in index["arrays"]:
            start, count = int(entry["offset"]), int(entry["words"])
            if start < 0 or count < 0 or start + count > words.size:
                raise ExrError(f"its array '{entry['name']}' lies outside the image")
            arrays[str(entry["name"])] = words[start:start + count].view(np.dtype(entry["dtype"]))
    except (KeyError, TypeError, ValueError) as err:
        raise ExrError(f"its index cannot be read ({err})") from None
    return arrays


def read(path: Path) -> dict[str, np.ndarray]:
    """``decode`` of a file on disk."""
    return decode(np.fromfile(path, np.uint8))


def write(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """``encode`` into ``path``, whole or not at all (written aside, then moved into place)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(f"{path.stem}.{os.getpid()}.partial{path.suffix}")
    partial.write_bytes(encode(arrays))
    partial.replace(path)
