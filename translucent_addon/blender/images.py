"""Images' pixels as the frame reads them: named by a stamp, cached on the session while unchanged."""
from __future__ import annotations

import numpy as np

from .session import Session, current


def image_stamp(image) -> tuple:
    """What names an image's pixels while it is not dirty: the datablock, its size and its file's time.
    The datablock by its session uid, never reused in a session: a freed image's address is soon given to a
    new one (a world made again after a file is reset read the old sky in 4 of 20 tries)."""
    import os

    path = image.filepath_from_user() if image.source == "FILE" else ""
    stamp = os.path.getmtime(path) if path and os.path.isfile(path) else 0.0  # a file changed on disk
    return image.name, image.session_uid, tuple(image.size), path, stamp



def image_data(image, derive, session: Session | None = None):
    """(``derive(pixels)``, the image's name): ``derive`` of an image's pixels ((H, W, C) float32, row 0 at the
    bottom, Blender's pixel order), kept on ``session`` while the image is unchanged (not dirty: a painted image
    is read again every frame, so what is made of it follows the brush). ValueError for an image with no pixels."""
    session = session or current()
    key = (image_stamp(image), derive.__module__, derive.__qualname__)
    cached = session.images.get(key)
    if cached is not None and not image.is_dirty:
        return cached, image.name
    w, h = image.size
    if w == 0 or h == 0:
        raise ValueError(f"image '{image.name}' has no pixels (is the file missing?)")
    px = np.empty(w * h * image.channels, np.float32)
    image.pixels.foreach_get(px)
    derived = derive(px.reshape(h, w, image.channels))
    if len(session.images) > 16:
        session.images.clear()
    session.images[key] = derived
    return derived, image.name
