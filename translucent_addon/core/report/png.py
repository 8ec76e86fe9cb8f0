"""A minimal 8-bit RGB/RGBA PNG writer and reader (NumPy, zlib, struct): the report's images without
matplotlib or Pillow, which the extension does not bundle. Pure."""
from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_CHANNELS = {2: 3, 6: 4}  # PNG colour type -> channels: truecolour, truecolour with alpha


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def _paeth(a, b, c):
    """The Paeth predictor of each byte from its left (a), upper (b) and upper-left (c) neighbours."""
    p = a + b - c
    pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
    return np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))


def _filter_rows(image: np.ndarray, filter_type: int) -> np.ndarray:
    """Each row of an (H, W, C) uint8 image as its filter-type byte and filtered bytes (H, 1 + W * C).
    Filtering reads only the original bytes, so every type vectorises; uint8 arithmetic wraps modulo 256
    as PNG wants (Paeth compares in int16)."""
    h, w, c = image.shape
    x = image.reshape(h, w * c)
    out = np.empty((h, 1 + w * c), np.uint8)
    out[:, 0] = filter_type
    body = out[:, 1:]
    body[:] = x
    if filter_type in (1, 3, 4):
        a = np.zeros_like(x)
        a[:, c:] = x[:, :-c]  # the byte one pixel to the left
    if filter_type in (2, 3, 4):
        b = np.zeros_like(x)
        b[1:] = x[:-1]  # the byte above
    if filter_type == 1:
        body -= a
    elif filter_type == 2:
        body -= b
    elif filter_type == 3:
        body -= (a >> 1) + (b >> 1) + (a & b & 1)  # floor((a + b) / 2) without overflow
    elif filter_type == 4:
        cc = np.zeros_like(x)
        cc[1:, c:] = x[:-1, :-c]  # the byte above and to the left
        body -= _paeth(a.astype(np.int16), b.astype(np.int16), cc.astype(np.int16)).astype(np.uint8)
    return out


def write_png(path: str | Path, image: np.ndarray, filter_type: int = 1, level: int = 6) -> None:
    """Write an (H, W, 3) RGB or (H, W, 4) RGBA uint8 image, top row first, as an 8-bit PNG.
    The Sub filter (1, the default) makes the flat areas of charts and renders compress well."""
    image = np.ascontiguousarray(image)
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] not in (3, 4) or 0 in image.shape[:2]:
        raise ValueError(f"write_png takes an (H, W, 3|4) uint8 image, not {image.dtype} {image.shape}")
    if filter_type not in range(5):
        raise ValueError(f"no PNG filter type {filter_type}")
    h, w, c = image.shape
    header = struct.pack(">IIBBBBB", w, h, 8, 2 if c == 3 else 6, 0, 0, 0)
    data = zlib.compress(_filter_rows(image, filter_type), level)
    Path(path).write_bytes(_SIGNATURE + _chunk(b"IHDR", header) + _chunk(b"IDAT", data) + _chunk(b"IEND", b""))


def _unfilter_row(kind: int, row: np.ndarray, prior: np.ndarray, bpp: int) -> np.ndarray:
    """Undo one row's filter. None and Up vectorise; Sub is a running sum per channel; Average and Paeth
    depend on the decoded byte to the left, so they go byte by byte (only foreign files use them)."""
    if kind == 0:
        return row
    if kind == 2:
        return row + prior  # uint8 arithmetic wraps, as the PNG specification wants
    if kind == 1:
        return np.cumsum(row.reshape(-1, bpp), axis=0, dtype=np.uint8).reshape(-1)
    if kind not in (3, 4):
        raise ValueError(f"unknown PNG filter type {kind}")
    out, up, raw = bytearray(row.tobytes()), prior.tobytes(), row.tobytes()
    for i in range(len(raw)):
        left = out[i - bpp] if i >= bpp else 0
        if kind == 3:
            out[i] = (raw[i] + ((left + up[i]) >> 1)) & 0xFF
        else:
            ul = up[i - bpp] if i >= bpp else 0
            p = left + up[i] - ul
            pa, pb, pc = abs(p - left), abs(p - up[i]), abs(p - ul)
            pred = left if pa <= pb and pa <= pc else (up[i] if pb <= pc else ul)
            out[i] = (raw[i] + pred) & 0xFF
    return np.frombuffer(bytes(out), np.uint8)


def read_png(path: str | Path) -> np.ndarray:
    """Read an 8-bit RGB or RGBA, non-interlaced PNG (what write_png makes, and most others) as an
    (H, W, 3|4) uint8 array, top row first. Raises ValueError on anything else."""
    data = Path(path).read_bytes()
    if not data.startswith(_SIGNATURE):
        raise ValueError(f"{path} is not a PNG")
    pos, header, idat = len(_SIGNATURE), None, []
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        crc = data[pos + 8 + length:pos + 12 + length]
        if len(body) != length or len(crc) != 4 or struct.unpack(">I", crc)[0] != zlib.crc32(kind + body) & 0xFFFFFFFF:
            raise ValueError(f"{path}: truncated or corrupt {kind!r} chunk")
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + length
    if header is None or not idat:
        raise ValueError(f"{path}: no image header or data")
    w, h, depth, colour, compression, filtering, interlace = header
    if depth != 8 or colour not in _CHANNELS or compression or filtering or interlace:
        raise ValueError(f"{path}: only 8-bit RGB/RGBA non-interlaced PNGs are read (depth {depth}, colour type "
                         f"{colour}, interlace {interlace})")
    c = _CHANNELS[colour]
    try:
        raw = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8)
    except zlib.error as exc:
        raise ValueError(f"{path}: bad image data ({exc})") from None
    if raw.size != h * (1 + w * c):
        raise ValueError(f"{path}: {raw.size} bytes of image data, not {h * (1 + w * c)}")
    rows = raw.reshape(h, 1 + w * c)
    out = np.empty((h, w * c), np.uint8)
    prior = np.zeros(w * c, np.uint8)
    for y in range(h):
        prior = out[y] = _unfilter_row(int(rows[y, 0]), rows[y, 1:], prior, c)
    return out.reshape(h, w, c)
