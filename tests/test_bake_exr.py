"""Bake arrays as an OpenEXR image (core/bake_exr.py): every stored dtype comes back bit for bit (NaN payloads and
float16 pairs included), the file is the OpenEXR layout its header says (checked field by field against the
format's definition, independently of the reader), and damage is refused, never read past. Pure."""
from __future__ import annotations

import struct

import numpy as np
import pytest
from exr_read import read_exr

from translucent_addon.core import bake_exr, bake_store


def _arrays():
    rng = np.random.default_rng(7)
    weird = np.array([0x7FC00001, 0x7F800000, 0xFF800000, 1, 0x80000000], np.uint32).view(np.float32)  # NaN, inf, ...
    return {
        "kernel": rng.random(5000, dtype=np.float32),
        "weird": weird,
        "index": np.arange(-3, 9000, dtype=np.int32),
        "double": rng.random(33),
        "empty": np.zeros(0, np.float32),
        "halves": rng.random(12).astype(np.float16).view(np.int32),  # float16 kept two to an int32 by bake_store
    }


def test_every_word_comes_back_unchanged():
    arrays = _arrays()
    back = bake_exr.decode(bake_exr.encode(arrays))
    assert sorted(back) == sorted(arrays)
    for name, a in arrays.items():
        assert back[name].dtype == a.dtype and back[name].shape == a.shape
        assert back[name].tobytes() == a.tobytes(), name


def test_the_file_is_the_openexr_scanline_layout_it_claims():
    arrays = {"a": np.arange(bake_exr.WIDTH + 10, dtype=np.float32)}  # two lines, the second padded
    data = bake_exr.encode(arrays)
    assert struct.unpack_from("<ii", data, 0) == (20000630, 2)  # magic, version 2 single-part scanline
    header_end = data.index(b"translucentBake\0string\0")
    size = struct.unpack_from("<i", data, header_end + len(b"translucentBake\0string\0"))[0]
    table = header_end + len(b"translucentBake\0string\0") + 4 + size + 1  # the attribute, then the header's 0
    assert data[table - 1] == 0
    for name in (b"channels\0chlist\0", b"compression\0compression\0", b"dataWindow\0box2i\0",
                 b"displayWindow\0box2i\0", b"lineOrder\0lineOrder\0", b"pixelAspectRatio\0float\0",
                 b"screenWindowCenter\0v2f\0", b"screenWindowWidth\0float\0"):
        assert name in data[:table]  # every attribute the format requires
    at = data.index(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0") + 4
    assert struct.unpack_from("<4i", data, at) == (0, 0, bake_exr.WIDTH - 1, 1)
    first, second = struct.unpack_from("<QQ", data, table)
    line = 8 + 4 * bake_exr.WIDTH
    assert second - first == line and first == table + 16 and len(data) == first + 2 * line
    assert struct.unpack_from("<ii", data, first) == (0, 4 * bake_exr.WIDTH)  # chunk: its y, its byte count
    assert struct.unpack_from("<ii", data, second) == (1, 4 * bake_exr.WIDTH)
    values = np.frombuffer(data, "<f4", bake_exr.WIDTH, second + 8)
    np.testing.assert_array_equal(values[:10], np.arange(bake_exr.WIDTH, bake_exr.WIDTH + 10))
    assert not values[10:].any()


def test_another_openexr_reader_reads_the_words(tmp_path):
    """``tests/exr_read.py``, written for Blender's own render files, reads the bake image: its Y channel holds the
    arrays' words in order, the rest of the last line zero."""
    arrays = {"a": np.arange(5000, dtype=np.float32), "b": np.arange(7, dtype=np.int32)}
    bake_exr.write(tmp_path / "bake.exr", arrays)
    y = read_exr(tmp_path / "bake.exr")["Y"]
    assert y.shape == (2, bake_exr.WIDTH)
    words = np.ascontiguousarray(y[::-1]).reshape(-1).view(np.uint32)  # row 0 at the bottom, as Blender's
    expected = np.concatenate([arrays["a"].view(np.uint32), arrays["b"].view(np.uint32)])
    np.testing.assert_array_equal(words[:expected.size], expected)
    assert not words[expected.size:].any()


@pytest.mark.parametrize("damage, said", [
    (lambda d: b"PK" + d[2:], "not an OpenEXR file"),
    (lambda d: d[:len(d) // 2], "cut short"),
    (lambda d: d[:40], "header"),
    (lambda d: d.replace(b"translucentBake", b"somethingElse!!"), "holds no bake"),
])
def test_damage_is_refused(damage, said):
    data = bake_exr.encode(_arrays())
    with pytest.raises(bake_exr.ExrError, match=said):
        bake_exr.decode(damage(data))


def test_a_sidecar_writes_image_files_and_still_reads_and_converts_npz_ones(tmp_path):
    """Bakes from before image files kept their arrays in ``<hash>.npz``: read as they are, converted unchanged."""
    arrays = {"big": np.arange(bake_store.SIDECAR_MIN_BYTES // 4, dtype=np.float32),
              "h": np.linspace(0, 1, 9).astype(np.float16)}
    sidecar = bake_store.Sidecar(tmp_path)
    old = {}
    bake_store.write(old, "TEXTURE_SPACE", "h", arrays, {"a": 1}, sidecar=sidecar)
    group = old["translucent_bake"]["TEXTURE_SPACE"]
    stored = bake_exr.read(group["image"])
    np.savez(tmp_path / "old.npz", **stored)  # as the earlier format wrote it
    del group["image"]
    group["file"] = str(tmp_path / "old.npz")
    assert bake_store.files(old) == {"TEXTURE_SPACE": str(tmp_path / "old.npz")}
    np.testing.assert_array_equal(bake_store.read(old, "TEXTURE_SPACE", sidecar).arrays["h"], arrays["h"])
    bake_store.convert(old, "TEXTURE_SPACE", sidecar)
    assert bake_store.files(old) == {} and bake_store.images(old)["TEXTURE_SPACE"].endswith(".exr")
    record = bake_store.read(old, "TEXTURE_SPACE", sidecar)
    for name, a in arrays.items():
        np.testing.assert_array_equal(record.arrays[name], a)
