"""The one owner of what a Blender session caches and remembers between frames (thin, bpy-facing).

Every cache the Blender layer keeps (the meshes as last read, the corner arrays drawn from them, the world's
image, the height maps, a bake's geometry and inputs hash), the F12 pipeline and what the last frame left for
the panels (its timings, its captured passes, each technique's ``results``) live on one ``Session``. The
extension makes one when it is enabled and drops it when it is disabled and when a file is loaded
(``reset``); the functions that read the scene take the session they fill (``extract.frame_inputs``,
``bake_inputs.gather``, ...), so that a test can run two side by side. ``current()`` is the extension's, the
one documented piece of mutable module state of this layer.
"""
from __future__ import annotations

import itertools
import uuid

import bpy

from . import mesh_read


class Session:
    """What one run of the extension caches and remembers."""

    def __init__(self):
        self.reads = mesh_read.Reads()  # meshes as last read, per (depsgraph mode, object)
        self.drawn: dict = {}  # (depsgraph mode, object) -> extract.DrawnMesh
        # Names each new DrawnMesh's GPU arrays: this session's mark and a serial, so that two sessions drawing
        # with one pipeline never hand it the same key for different arrays.
        self.mark = uuid.uuid4().hex[:8]
        self.drawn_serials = itertools.count(1)
        self.turned: dict[str, int] = {}  # object -> closed parts its last frame drew turned outward
        self.environment: dict = {}  # the world's image as last read (extract.world_environment)
        self.images: dict = {}  # what techniques made of images' pixels, as last read (extract.image_data)
        self.passes: dict = {}  # the last F12's render passes besides Combined (engine.pass_images)
        self.surfaces: dict = {}  # (mode, object) -> (what it was made of, core.surface.Surface) (extract)
        self.bake_arrays: dict = {}  # (read key, corner normals?) -> (MeshRead, a bake's geometry arrays)
        self.bake_hashes: dict = {}  # (mode, object, method) -> (geometry arrays, parameters JSON, inputs hash)
        self.final_pipeline = None  # the F12 / animation pipeline, kept across renders (engine.final_pipeline)
        self.timings: dict = {}  # seconds per pass of the last frame drawn (F12 or viewport)
        self.warnings: list[str] = []  # the last frame's warnings (F12 or viewport; the Last Frame panel)
        self.capture: dict = {}  # read-backs of the last F12's passes (Scene.translucent.capture_passes)
        self.results: dict = {}  # technique id -> what its ``frame_settings`` left of the last frame
        self.technique_caches: dict = {}  # technique id -> its own cache across frames (``frame_settings``)
        self.before_copy: list = []  # (kind, name, method, reference) before a save moved bake files (bake_files)
        # Bake files the file on disk refers to, and every one referred to since it was opened (the purges keep them:
        # a revert, an Undo step or the .blend1 backup may read them); None until a file is opened with the extension
        # enabled, when Undo may reach bakes this session never saw: no purge on save then (bake_files).
        self.bake_files_saved: set = set()
        self.bake_files_seen: set | None = None
        self.cycles_rates: dict = {}  # (scene, width, height) -> Cycles' measured cost (compare_runner.cycles_rate)
        # Kept while the extension is enabled (``clear`` leaves them): Blender keeps pointers into the preset
        # enum's item strings, and a preset's coefficients are being written (props.apply_preset).
        self.preset_items: list = []
        self.preset_problems: list[str] = []  # what the user presets file's last reading skipped
        self.applying_preset = False
        self.overlay_pipeline = None  # the pipeline drawing over other engines' viewports (draw_handler)
        self.overlay_frames = 0  # overlay frames drawn: the temporal coherence's sequence
        # Registration, not a cache (``clear`` keeps it): the viewport draw handlers added (draw_handler).
        self.handlers: dict = {}

    def clear(self) -> None:
        """Drop every cache (the pipelines with them) and what the last frame said (a file was loaded); the draw
        handlers stay."""
        self.reads.clear()
        for d in (self.drawn, self.turned, self.environment, self.images, self.surfaces, self.bake_arrays,
                  self.bake_hashes, self.timings, self.warnings, self.capture, self.results, self.technique_caches,
                  self.cycles_rates):
            d.clear()
        # Dropped, not freed: a load_post handler runs outside a GPU context, and the pipelines' GPU objects free
        # themselves when the last reference goes.
        self.final_pipeline = self.overlay_pipeline = None


_current = Session()  # the extension's session (``reset`` replaces it)


def current() -> Session:
    """The extension's session."""
    return _current


def reset() -> Session:
    """A new session for the extension (enabled, disabled, a file loaded): the old one's caches are dropped."""
    global _current
    _current.clear()
    _current = Session()
    return _current


@bpy.app.handlers.persistent
def _loaded(*_args) -> None:
    """load_post: another file's meshes, bakes and last frame are not this one's."""
    _current.clear()


def register() -> None:
    if _loaded not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(_loaded)


def unregister() -> None:
    """The extension is disabled: its handler goes and the session is replaced by an empty one."""
    if _loaded in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_loaded)
    reset()
