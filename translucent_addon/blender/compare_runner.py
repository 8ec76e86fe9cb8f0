"""Compare with Cycles: our engine, Cycles (random walk, brute force), EEVEE and the dipole model.

Renders the scene camera's view at the scene resolution with every engine and quality setting,
measures each against a reference over the pixels of the translucent objects, and writes
report.json, the images, false-colour error images and the speed-vs-accuracy chart. The
reference (Cycles random walk at many samples unless chosen otherwise) and the brute-force
check are cached by a hash of everything that made them.
Blender-facing: swaps twin materials onto the objects for the other engines and restores them.
"""
from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import os
import platform
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

from .. import techniques
from ..core.geometry.camera import pixel_rays
from ..core.geometry.orientation import orient_outward
from ..core.metrics import median_relative_error, relative_rmse, ssim
from ..core.reference import cache
from ..core.reference.dipole_model import Medium, render_dipole
from ..core.reference.lambert import scene_triangles
from ..core.report.report import (
    Entry,
    reference_noise,
    save_error_png,
    save_image_png,
    speed_accuracy_chart,
    write_report,
)
from ..techniques import registry
from ..techniques.protocol import Variant
from . import bake_files, extract, medium_source, twin_materials
from .bake_inputs import bake_status, gather
from .bvh_tracer import BVHTracer
from .quality_apply import apply_auto
from .session import current as current_session
from .versions import EEVEE_IDS, eevee_engine_id


class CompareError(RuntimeError):
    """The comparison cannot run; the message says what and why."""


@dataclasses.dataclass
class CompareSettings:
    cycles_random_walk_samples: tuple = (4, 16, 64, 256)
    cycles_brute_force_samples: tuple = (16, 64)
    eevee_samples: tuple = (1, 4, 16, 64)
    reference_samples: int = 1024  # Cycles random walk: the reference
    brute_force_reference_samples: int = 256  # the brute-force check of the reference (0: off)
    model_reference_samples: int = 200_000  # CPU dipole model (0: off)
    cycles_bounces: int = 1024
    cache_dir: str = ""  # default: <output_dir>/cache
    # Our methods' series: technique id -> the values its ``compare_variants`` draws (splat overlaps, atlas
    # resolutions, densities K), () for none; a method not named here draws its own defaults
    # (``Technique.compare_defaults``, or ``compare_quick``) where an object uses it. The objects' method and
    # values are restored after.
    series: dict = dataclasses.field(default_factory=dict)
    quick: bool = False
    auto_targets: tuple = ()  # Quality = Auto at these target errors (the benchmark: 0.05)
    auto_methods: tuple = ()  # ... for these methods; (): the objects' methods that have an Auto

    @classmethod
    def quick_settings(cls) -> "CompareSettings":
        """Minutes-not-hours settings for tests and a first look."""
        return cls(cycles_random_walk_samples=(4, 16), cycles_brute_force_samples=(16,), eevee_samples=(1, 4),
                   reference_samples=64, brute_force_reference_samples=64, model_reference_samples=20_000,
                   quick=True)

    def variants(self, methods=()) -> list:
        """(technique, Variant) of every image of ours, in registry order: the series named here, and the
        defaults of the objects' ``methods`` not named."""
        out = []
        for t in techniques.REGISTRY:
            if t.id in self.series:
                values = tuple(self.series[t.id])
                chosen = t.compare_variants(values) if values else []
            elif t.id in methods:
                values = t.compare_quick if self.quick else t.compare_defaults
                chosen = t.compare_variants(values) if values else [Variant("as set")]
            else:
                continue
            out += [(t, v) for v in chosen]
        return out

    def auto_series(self, methods=()) -> list:
        """The methods drawn at Quality = Auto (those that have one) when there are targets."""
        if not self.auto_targets:
            return []
        named = self.auto_methods or tuple(methods)
        return [t for t in techniques.REGISTRY if t.id in named and t.has_auto_quality]

    def cycles_pixel_samples(self) -> int:
        """Samples per pixel the comparison asks of Cycles, every render together (the reference's two halves,
        its check, the random walk and brute force series)."""
        return int(2 * max(1, self.reference_samples // 2) + self.brute_force_reference_samples
                   + sum(self.cycles_random_walk_samples) + sum(self.cycles_brute_force_samples))

    def renders(self, methods=()) -> int:
        return (2 + bool(self.brute_force_reference_samples) + len(self.cycles_random_walk_samples)
                + len(self.cycles_brute_force_samples) + len(self.eevee_samples) + len(self.variants(methods))
                + len(self.auto_targets) * len(self.auto_series(methods)))


REFERENCE_SEEDS = (1001, 1002)


def cycles_rate(scene) -> tuple[float, float]:
    """Cycles' cost on this scene and machine: (seconds a render costs whatever its samples, seconds per sample
    at the scene's resolution), from renders of a quarter of its pixels (1 and 5 samples after a first one, the
    random walk as the scene stands; about a second), kept for the session."""
    width, height = extract.output_size(scene.render)
    key = (scene.name, width, height)
    rates = current_session().cycles_rates
    if key not in rates:
        small = (max(1, width // 2), max(1, height // 2))
        timed = []
        for samples in (1, 1, 5):  # the first loads the kernels and builds the BVH: not timed
            with engine_setup(scene, "CYCLES", **cycles_options(samples, 64)):
                timed.append(render_pixels(scene, *small)[1])
        per_sample = max(timed[2] - timed[1], 1e-4) / 4.0 * (width * height) / (small[0] * small[1])
        rates[key] = (max(timed[1] - per_sample / 4.0, 0.0), per_sample)
    return rates[key]


def expected_seconds(scene, settings: CompareSettings) -> float:
    """About how long a comparison takes here: Cycles at its measured rate (``cycles_rate``), the rest at a
    few seconds a render (a variant of a method that bakes at about a minute more). Cached references count
    as nothing only when they are found; this says the time without a cache."""
    overhead, per_sample = cycles_rate(scene)
    cycles_renders = (2 + bool(settings.brute_force_reference_samples) + len(settings.cycles_random_walk_samples)
                      + len(settings.cycles_brute_force_samples))
    cycles = cycles_renders * overhead + settings.cycles_pixel_samples() * per_sample
    methods = object_methods(translucent_objects(scene))
    baked = sum(bool(t.bake_stages) for t, _ in settings.variants(methods))
    others = 3.0 * (settings.renders(methods) - cycles_renders) + 60.0 * baked
    return cycles + others


def exact_reference_converges(scene, objects) -> tuple[bool, str]:
    """(whether Cycles' brute force converges on this scene, why). It is exact transport; it converges where
    paths inside the medium can reach the lights: the media index-matched (no surface to refract at), or a
    refracting boundary lit only by area lights and the world. Point, spot and sun lights behind a refracting
    boundary are reached only by chance, and the random walk (a diffusion-like peer that keeps 20-30 % of
    the light through thin back-lit parts) is then the reference."""
    if all(medium_source.resolve(ob).eta <= twin_materials.INDEX_MATCHED for ob in objects):
        return True, "exact transport: Cycles brute force, the media index-matched"
    small = sorted({ob.data.type.lower() for ob in scene.objects
                    if ob.type == "LIGHT" and ob.visible_get() and ob.data.type != "AREA"})
    if not small:
        return True, "exact transport: Cycles brute force under area lights and the world"
    return False, (f"Cycles random walk, not exact transport: Cycles brute force does not converge with "
                   f"{' and '.join(small)} lights behind a refracting boundary (set IOR 1 or use area lights "
                   f"for an exact reference)")


def object_methods(objects) -> list[str]:
    """The objects' methods, each once, in their order."""
    return list(dict.fromkeys(ob.translucent.method for ob in objects))


def translucent_objects(scene) -> list:
    return [ob for ob in scene.objects if ob.type == "MESH" and ob.visible_get()
            and ob.translucent.method != "OFF"]


# -- rendering through an engine -------------------------------------------------------
def render_pixels(scene, width: int, height: int) -> tuple[np.ndarray, float]:
    """F12 with the scene's engine: linear RGBA (height, width, 4) and the seconds it took."""
    r = scene.render
    saved = (r.resolution_x, r.resolution_y, r.resolution_percentage, r.filepath,
             r.image_settings.file_format, r.image_settings.color_depth)
    fd, path = tempfile.mkstemp(suffix=".exr")
    os.close(fd)
    try:
        r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
        r.image_settings.file_format = "OPEN_EXR"
        r.image_settings.color_depth = "32"
        r.filepath = path
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=True, scene=scene.name)
        seconds = time.perf_counter() - t0
        image = bpy.data.images.load(path)
        try:
            px = np.empty(len(image.pixels), np.float32)
            image.pixels.foreach_get(px)
        finally:
            bpy.data.images.remove(image)
        return px.reshape(height, width, 4), seconds
    finally:
        (r.resolution_x, r.resolution_y, r.resolution_percentage, r.filepath,
         r.image_settings.file_format, r.image_settings.color_depth) = saved
        os.remove(path)


@contextlib.contextmanager
def engine_setup(scene, engine: str, **options):
    """Set the render engine and its options for the duration of a block, then restore."""
    saved_engine = scene.render.engine
    saved = {}
    target = scene.cycles if engine == "CYCLES" else scene.eevee if engine in EEVEE_IDS else None
    try:
        scene.render.engine = engine
        for name, value in options.items():
            owner, attr = (scene.translucent, name[len("translucent_"):]) if name.startswith("translucent_") \
                else (target, name)
            saved[(id(owner), attr)] = (owner, attr, getattr(owner, attr))
            setattr(owner, attr, value)
        yield
    finally:
        for owner, attr, value in saved.values():
            setattr(owner, attr, value)
        scene.render.engine = saved_engine


@contextlib.contextmanager
def twin_materials_applied(objects, kind: str, **options):
    """Give each translucent object the twin material of its medium, restore afterwards (``options`` go
    to the material's factory in ``twin_materials``). An object wound inward renders its outward twin
    (``outward_meshes_applied``): a volume behind inward faces was black in Cycles."""
    with outward_meshes_applied(objects), _materials_swapped(objects, kind, options):
        yield


@contextlib.contextmanager
def _materials_swapped(objects, kind: str, options: dict):
    """Each object's slots given the twin of its medium for the duration; for the random walk, an object whose
    medium is its Principled BSDF's keeps its own material (textures, gloss, normal maps, several slots: what the
    artist renders), the brute force has no surface shader to keep."""
    saved = []
    made = []
    try:
        # Media and slots read before any slot changes: linked duplicates share their mesh's slots.
        media = [medium_source.resolve(ob) for ob in objects]
        saved = [(ob, [slot.material for slot in ob.material_slots]) for ob in objects]
        for ob, m in zip(objects, media):
            if kind == "random_walk" and m.source == "PRINCIPLED":
                continue  # the artist's own material is what the random walk renders: its textures, gloss, slots
            mat = getattr(twin_materials, kind)(f"{ob.name} ({kind})", m.sigma_a, m.sigma_s_prime, m.eta, m.g,
                                                m.mm_per_unit, **options)
            made.append(mat)
            if not ob.material_slots:
                ob.data.materials.append(None)
            for slot in ob.material_slots:
                slot.material = mat
        yield
    finally:
        for ob, mats in reversed(saved):  # the first object's slots last: its mesh as it was
            if not mats:
                ob.data.materials.clear()
            for slot, mat in zip(ob.material_slots, mats):
                slot.material = mat
        for mat in made:
            bpy.data.materials.remove(mat)


@contextlib.contextmanager
def outward_meshes_applied(objects):
    """Objects with inward-wound parts (``core/geometry/orientation``) get, for the duration, a copy of their
    evaluated mesh with those parts' faces reversed and their modifiers off; restored afterwards."""
    import bmesh

    depsgraph = bpy.context.evaluated_depsgraph_get()
    swapped = []
    try:
        for ob in objects:
            ob_eval = ob.evaluated_get(depsgraph)
            mesh = bpy.data.meshes.new_from_object(ob_eval, preserve_all_data_layers=True, depsgraph=depsgraph)
            mesh.calc_loop_triangles()
            vertices = np.empty(len(mesh.vertices) * 3, np.float32)
            mesh.vertices.foreach_get("co", vertices)
            triangles = np.empty(len(mesh.loop_triangles) * 3, np.int32)
            mesh.loop_triangles.foreach_get("vertices", triangles)
            polygon = np.empty(len(mesh.loop_triangles), np.int32)
            mesh.loop_triangles.foreach_get("polygon_index", polygon)
            flip = orient_outward(vertices.reshape(-1, 3), triangles.reshape(-1, 3)).flip
            if not flip.any():
                bpy.data.meshes.remove(mesh)
                continue
            bm = bmesh.new()
            bm.from_mesh(mesh)
            bm.faces.ensure_lookup_table()
            bmesh.ops.reverse_faces(bm, faces=[bm.faces[i] for i in np.unique(polygon[flip])])
            bm.to_mesh(mesh)
            bm.free()
            modifiers = [(m, m.show_render, m.show_viewport) for m in ob.modifiers]
            for m, _, _ in modifiers:
                m.show_render = m.show_viewport = False
            swapped.append((ob, ob.data, mesh, modifiers))
            ob.data = mesh
        yield
    finally:
        for ob, data, mesh, modifiers in swapped:
            ob.data = data
            for m, render, viewport in modifiers:
                m.show_render, m.show_viewport = render, viewport
            bpy.data.meshes.remove(mesh)


def cycles_options(samples: int, bounces: int, seed: int = 1) -> dict:
    return dict(device="CPU", samples=samples, use_adaptive_sampling=False, use_denoising=False, seed=seed,
                max_bounces=bounces, volume_bounces=bounces, transmission_bounces=bounces, glossy_bounces=bounces,
                diffuse_bounces=bounces, transparent_max_bounces=bounces, caustics_reflective=True,
                caustics_refractive=True, blur_glossy=0.0, sample_clamp_direct=0.0, sample_clamp_indirect=0.0,
                pixel_filter_type="BOX")


def eevee_options(samples: int) -> dict:
    return dict(taa_render_samples=samples)


# -- what the renders depend on (cache keys) -----------------------------------------------
def scene_description(depsgraph, frame, objects) -> dict:
    """Everything of the scene that a render depends on, as hashable values."""
    h = hashlib.blake2b(digest_size=12)
    for m in frame.meshes:  # not m.key: that hashes the corners in Blender's order, which can change
        h.update(m.name.encode())
        h.update(cache.corner_digest(m.positions, m.colors).encode())
        h.update(cache.normals_digest(m.positions, m.normals).encode())
        h.update(np.asarray(m.model, np.float64).tobytes())
    for e in frame.emitters:
        h.update(repr(e).encode())
    h.update(np.asarray(frame.camera.view_proj).tobytes())
    media = {ob.name: [list(m.sigma_a), list(m.sigma_s_prime), m.eta, m.g, m.mm_per_unit]
             for ob in objects for m in (medium_source.resolve(ob),)}
    return {"geometry_lights_camera": h.hexdigest(), "world": list(map(float, frame.world_color)), "media": media,
            "size": [frame.camera.width, frame.camera.height], "blender": bpy.app.version_string}


def interior(mask: np.ndarray) -> np.ndarray:
    """The mask without its one-pixel border: silhouette pixels are anti-aliased by Cycles and EEVEE,
    point-sampled by rasterisers and ray casts, so no renderer can agree on them."""
    from scipy.ndimage import binary_erosion

    return binary_erosion(mask, iterations=1)


def _mask(frame, tracer, names: set[str]) -> np.ndarray:
    cam = frame.camera
    origins, dirs = pixel_rays(cam.view_proj, cam.width, cam.height)
    _, tri, _, _ = tracer.closest_hit(origins.reshape(-1, 3), dirs.reshape(-1, 3))
    owner = np.full(len(tri), -1)
    offsets = np.cumsum([0] + [m.triangle_count for m in frame.meshes])
    hit = tri >= 0
    owner[hit] = np.searchsorted(offsets, tri[hit], side="right") - 1
    wanted = np.array([m.name in names for m in frame.meshes] + [False])
    return wanted[owner].reshape(cam.height, cam.width)


def run(scene, output_dir, settings: CompareSettings | None = None, progress=print, objects=None):
    """Run the whole comparison; returns (entries, meta) and writes everything into output_dir.

    ``objects``: the objects whose medium is compared (default: every visible mesh with a method).
    """
    job = run_steps(scene, output_dir, settings, objects)
    while True:
        try:
            _, text = next(job)
        except StopIteration as done:
            return done.value
        progress(text)


def run_steps(scene, output_dir, settings: CompareSettings | None = None, objects=None):
    """The comparison as a generator of (fraction done, text), one step per render, so that an operator
    can show progress and cancel between renders (no scene setting is left changed between steps);
    returns (entries, meta)."""
    c = _Comparison(scene, output_dir, settings or CompareSettings(), objects)
    yield from c.reference()
    yield from c.engines()
    yield from c.ours()
    yield from c.model()
    c.measure()
    meta = c.write()
    yield 1.0, f"wrote {c.out / 'report.json'} and {c.out / 'chart.png'}"
    return c.entries, meta


class _Comparison:
    """One comparison as it runs (``run_steps``): the scene and what is measured on it, the renders so far
    (``images``, ``entries``) and the reference they are measured against."""

    def __init__(self, scene, output_dir, settings: CompareSettings, objects):
        """What every render shares: the output folder, the objects, their interior pixels, the scene's
        description (the cache key); CompareError where there is nothing to compare."""
        self.scene, self.settings = scene, settings
        self.out = Path(bpy.path.abspath(str(output_dir)))
        self.out.mkdir(parents=True, exist_ok=True)
        self.cache_dir = Path(settings.cache_dir) if settings.cache_dir else self.out / "cache"
        if scene.camera is None:
            raise CompareError("the scene has no active camera: the comparison renders the camera's view")
        self.objects = list(objects) if objects is not None else translucent_objects(scene)
        if not self.objects:
            raise CompareError("no visible object has a translucency method (Object > Translucent > Method)")
        self.width, self.height = extract.output_size(scene.render)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        self.frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, self.width, self.height))
        self.tracer = BVHTracer(scene_triangles(self.frame)[0])
        self.names = {ob.name for ob in self.objects}
        self.mask = interior(_mask(self.frame, self.tracer, self.names))
        if not self.mask.any():
            raise CompareError("the translucent objects are not in the camera's view (or less than 3 pixels wide)")
        self.description = scene_description(depsgraph, self.frame, self.objects)
        self.methods = object_methods(self.objects)
        self.images: dict[str, np.ndarray] = {}
        self.entries: list[Entry] = []
        # The CPU dipole model where it models a method drawn here (light diffusing below the surface; not glass).
        self.model_samples = settings.model_reference_samples if any(
            getattr(techniques.get(m), "dipole_modelled", False) for m in self.methods) else 0
        self.total = settings.renders(self.methods) + bool(self.model_samples) + 1  # and the report
        self.steps = 0
        self.model_image = None

    def step(self, text):
        self.steps += 1
        return min(self.steps / self.total, 0.99), text

    def add(self, series, engine, label, seconds, image, cached=False, **extra):
        key = f"{series} {label}".strip()
        self.images[key] = image
        self.entries.append(Entry(series=series, engine=engine, settings={"label": label, **extra}, seconds=seconds,
                                  reference="", cached=cached))

    def cached_cycles(self, kind, samples, seed=1):
        """Generator: one Cycles render of the twin materials, from the cache when it holds it:
        (image, seconds, from the cache)."""
        desc = {**self.description, "engine": "CYCLES", "kind": kind, "samples": samples,
                "bounces": self.settings.cycles_bounces, **({"seed": seed} if seed != 1 else {})}
        hit = cache.load(self.cache_dir, desc)
        if hit is not None:
            yield self.step(f"Cycles {kind} {samples} spp: from the cache")
            return hit[0], hit[1], True
        yield self.step(f"Cycles {kind} {samples} spp ...")
        with twin_materials_applied(self.objects, kind), \
                engine_setup(self.scene, "CYCLES", **cycles_options(samples, self.settings.cycles_bounces, seed)):
            image, seconds = render_pixels(self.scene, self.width, self.height)
        cache.store(self.cache_dir, desc, image, seconds)
        return image, seconds, False

    def reference(self):
        """Generator: the reference first, so that every other render is measured against it: exact transport
        (Cycles' brute force) where it converges, else the random walk, with the reason in the report; and the
        other of the two as its check."""
        settings = self.settings
        self.exact, self.why = exact_reference_converges(self.scene, self.objects)
        ref_kind, check_kind = ("brute_force", "random_walk") if self.exact else ("random_walk", "brute_force")
        ref_title = ref_kind.replace("_", " ")
        self.ref_name = f"Cycles {ref_title} {settings.reference_samples} spp"
        # Two independent halves, averaged: the reference at its full samples, and from their difference its own
        # noise, below which no error is resolved (report.reference_noise). Their seeds are none a series render
        # uses (seed 1): a 16-sample render would otherwise be the first 16 samples of a half, and its error low.
        half = max(1, settings.reference_samples // 2)
        half_a, seconds_a, cached_a = yield from self.cached_cycles(ref_kind, half, seed=REFERENCE_SEEDS[0])
        half_b, seconds_b, cached_b = yield from self.cached_cycles(ref_kind, half, seed=REFERENCE_SEEDS[1])
        self.ref_image = 0.5 * (half_a + half_b)
        self.noise = reference_noise(half_a, half_b, self.mask)
        self.add(f"Cycles {ref_title} (reference)", "CYCLES", f"{settings.reference_samples} spp",
                 seconds_a + seconds_b, self.ref_image, cached_a and cached_b, samples=settings.reference_samples)
        check_image = None
        if settings.brute_force_reference_samples:
            spp = settings.brute_force_reference_samples
            check_image, sec, hit = yield from self.cached_cycles(check_kind, spp)
            self.add(f"Cycles {check_kind.replace('_', ' ')} (check)", "CYCLES", f"{spp} spp", sec, check_image, hit,
                     samples=spp)
        self.brute_image = self.ref_image if self.exact else check_image

    def engines(self):
        """Generator: Cycles' random walk and brute force series, then EEVEE's (its first frame warmed)."""
        for spp in self.settings.cycles_random_walk_samples:
            img, sec, hit = yield from self.cached_cycles("random_walk", spp)
            self.add("Cycles random walk", "CYCLES", f"{spp} spp", sec, img, hit, samples=spp)
        for spp in self.settings.cycles_brute_force_samples:
            img, sec, hit = yield from self.cached_cycles("brute_force", spp)
            self.add("Cycles brute force", "CYCLES", f"{spp} spp", sec, img, hit, samples=spp)
        for i, spp in enumerate(self.settings.eevee_samples):
            yield self.step(f"EEVEE {spp} samples ...")
            with (twin_materials_applied(self.objects, "random_walk"),
                  engine_setup(self.scene, eevee_engine_id(), **eevee_options(spp))):
                if i == 0:
                    warm_eevee(self.scene, self.width, self.height)
                img, sec = render_pixels(self.scene, self.width, self.height)
            self.add("EEVEE", "BLENDER_EEVEE", f"{spp} samples", sec, img, samples=spp)

    def ours(self):
        """Generator: each method's variants (``CompareSettings.variants``), then Quality = Auto at each target."""
        scene, objects = self.scene, self.objects
        for technique, variant in self.settings.variants(self.methods):
            yield self.step(f"Translucent ({technique.id}) {variant.label} ...")
            bake_seconds, img, sec = draw_variant(scene, objects, technique, variant, self.width, self.height)
            self.add(f"Translucent ({technique.id})", "TRANSLUCENT_RT", variant.label, sec, img,
                     methods=[technique.id], **variant.record,
                     **({"bake_seconds": bake_seconds} if technique.bake_stages else {}))
        for target in self.settings.auto_targets:
            for technique in self.settings.auto_series(self.methods):
                method = technique.id
                yield self.step(f"Translucent Auto ({method}), target {target:g} ...")
                with method_applied(objects, method, quality="AUTO", target_error=target), scene_kept(scene):
                    choices = [apply_auto(bpy.context, ob) for ob in objects]
                    bake_seconds = (bake_objects(objects, method, lambda text: None)[0] if technique.bake_stages
                                    else 0.0)
                    img, sec = warm_render(scene, self.width, self.height)
                self.add(f"Translucent Auto ({method})", "TRANSLUCENT_RT", f"target {100 * target:g} %", sec, img,
                         methods=[method], target_error=target, bake_seconds=bake_seconds,
                         choice="; ".join(c.summary() for c in choices))

    def model(self):
        """Generator: the CPU dipole model of the objects (cached), when the settings ask for it and it models a
        method drawn."""
        samples = self.model_samples
        if not samples:
            return
        yield self.step(f"dipole model reference (CPU, {samples} samples) ...")
        self.model_image, sec, hit = model_reference(self.frame, self.objects, self.tracer, samples, self.description,
                                                     self.cache_dir, lambda text: None)
        self.add("Dipole model (CPU)", "CPU_DIPOLE_MODEL", f"{samples // 1000}k samples", sec, self.model_image, hit,
                 samples=samples)

    def measure(self) -> None:
        """Every render against the reference (and the model, the brute force), its image and error image."""
        mask, ref_image = self.mask, self.ref_image
        for e in self.entries:
            key = f"{e.series} {e.settings['label']}".strip()
            img = self.images[key]
            slug = "".join(c if c.isalnum() else "_" for c in key).strip("_").lower()
            e.image = f"{slug}.png"
            save_image_png(self.out / e.image, img)
            if e.series.endswith("(reference)"):
                e.reference = "itself"
                continue
            e.reference = self.ref_name
            e.rel_rmse = relative_rmse(img, ref_image, mask)
            e.ssim = ssim(img, ref_image, mask)
            e.median_rel_error = median_relative_error(img, ref_image, mask)
            e.below_reference_noise = bool(e.rel_rmse <= self.noise["rel_rmse"])
            if self.model_image is not None and e.engine == "TRANSLUCENT_RT":
                e.rel_rmse_model = relative_rmse(img, self.model_image, mask)
            if self.brute_image is not None and not e.series.startswith("Cycles brute force"):
                e.median_vs_brute_force = median_relative_error(img, self.brute_image, mask)
            e.error_image = f"{slug}_error.png"
            save_error_png(self.out / e.error_image, img, ref_image, mask)

    def write(self) -> dict:
        """report.json and chart.png; returns the report's meta."""
        meta = {
            "scene": self.scene.name, "size": [self.width, self.height], "objects": sorted(self.names),
            "reference": self.ref_name, "reference_exact": self.exact, "reference_why": self.why,
            "reference_noise": {k: round(float(v), 6) for k, v in self.noise.items()},
            "reference_noise_how": "each metric between the reference's two independent halves (seeds 1 and 2) "
                                   "over 2",
            "mask_pixels": int(self.mask.sum()), "machine": machine_description(), "blender": bpy.app.version_string,
            "error": "relative RMSE and SSIM of linear radiance over the translucent objects' pixels "
                     "(their silhouette pixels excluded)",
        }
        write_report(self.out / "report.json", self.entries, meta)
        speed_accuracy_chart(self.entries, self.out / "chart.png",
                             f"{self.scene.name}: speed against accuracy ({self.width}x{self.height}); "
                             f"reference {self.ref_name}", noise=self.noise)
        return meta


def bake_objects(objects, method: str, progress=print) -> tuple[float, list[dict]]:
    """Bake each object with the given method (blocking, as in batch mode): (seconds, each bake's meta)."""

    depsgraph = bpy.context.evaluated_depsgraph_get()
    t0 = time.perf_counter()
    metas = []
    for ob in objects:
        inputs = gather(ob.evaluated_get(depsgraph), method, for_bake=True)
        registry.validate(inputs)
        job = registry.run(inputs)
        try:
            while True:
                next(job)
        except StopIteration as done:
            arrays, meta = done.value
        bake_files.write(ob, method, inputs.hash(), arrays, meta, bpy.context.scene)
        metas.append(meta)
        progress(f"baked {ob.name} ({method}): {meta.get('proxy_vertices', '?')} proxy vertices, "
                 f"{time.perf_counter() - t0:.1f} s")
    return time.perf_counter() - t0, metas


def draw_variant(scene, objects, technique, variant, width: int, height: int):
    """The objects drawn with ``technique`` as ``variant`` sets them, baked first where the method bakes and the
    bake is not current: (bake seconds, image, seconds of the second frame)."""
    scene_options = {f"translucent_{k}": v for k, v in variant.scene_values.items()}
    with method_applied(objects, technique.id, **variant.object_values):
        depsgraph = bpy.context.evaluated_depsgraph_get()
        stale = [ob for ob in objects if technique.bake_stages
                 and bake_status(ob.evaluated_get(depsgraph), technique.id) != "OK"]
        bake_seconds = bake_objects(stale, technique.id, lambda text: None)[0] if stale else 0.0
        with engine_setup(scene, "TRANSLUCENT_RT", **scene_options):
            render_pixels(scene, width, height)  # the first frame uploads a bake and starts a relaxation cold
            img, sec = render_pixels(scene, width, height)
    return bake_seconds, img, sec


@contextlib.contextmanager
def method_applied(objects, method: str, **props):
    """The objects drawn with ``method`` and these Object.translucent values; every value restored after (those a
    method's Auto quality sets too)."""
    auto = [name for t in techniques.REGISTRY for name in (*t.bake_properties, *t.medium_properties)]
    names = ["method", *props, *auto, "auto_summary"]
    saved = [(ob, {n: getattr(ob.translucent, n) for n in dict.fromkeys(names)}) for ob in objects]
    try:
        for ob in objects:
            ob.translucent.method = method
            for name, value in props.items():
                setattr(ob.translucent, name, value)
        yield
    finally:
        for ob, values in saved:
            for name, value in values.items():
                setattr(ob.translucent, name, value)


@contextlib.contextmanager
def scene_kept(scene):
    """Scene.translucent's sampling values (which Auto may set) restored after."""
    names = ("splat_overlap", "splat_max_grid")
    saved = {n: getattr(scene.translucent, n) for n in names}
    try:
        yield
    finally:
        for name, value in saved.items():
            setattr(scene.translucent, name, value)


def warm_render(scene, width: int, height: int):
    """Our engine's second frame (the first uploads a bake and starts a relaxation cold): (image, seconds)."""
    with engine_setup(scene, "TRANSLUCENT_RT"):
        render_pixels(scene, width, height)
        return render_pixels(scene, width, height)


def warm_eevee(scene, width: int, height: int) -> None:
    """One untimed EEVEE frame at 1 sample and the size of the timed ones, so that those do not include
    its shader compilation and buffer setup (the first frame of a session costs more: the glass sphere at
    192x144 took 33 s at 4 samples cold against 19 s at 16 warm on this machine); our engine is timed
    warm in the same way."""
    saved = scene.eevee.taa_render_samples
    try:
        scene.eevee.taa_render_samples = 1
        render_pixels(scene, width, height)
    finally:
        scene.eevee.taa_render_samples = saved


def model_reference(frame, objects, tracer, samples: int, description: dict, cache_dir, progress):
    """The CPU dipole model of the translucent objects (cached): (image, seconds, from cache)."""
    # model 4: visibility by facet; the far side of thin parts in the far field; SH environment light;
    # the near disk corrected by the samples' irradiance where it differs from E(x_o)
    # model 5: the angular laws (a(mu) in and out; thin-part pairs leave by the diffusion mode's law)
    # model 6: light entering at an angle read where it entered (IMAGE_SPACE's, TEXTURE_SPACE's since)
    # model 7: the light leaving leans away from where it entered (IMAGE_SPACE's; TEXTURE_SPACE's lacks it)
    # model 8: ... across thin parts too
    desc = {**description, "engine": "CPU_DIPOLE_MODEL", "samples": samples, "model": 8}
    hit = cache.load(cache_dir, desc)
    if hit is not None:
        progress("dipole model reference: from the cache")
        return hit[0], hit[1], True
    media = {ob.name: Medium(m.sigma_a, m.sigma_s_prime, m.eta, m.mm_per_unit)
             for ob in objects for m in (medium_source.resolve(ob),)}
    progress(f"dipole model reference (CPU, {samples} samples) ...")
    t0 = time.perf_counter()
    image = render_dipole(frame, media, samples=samples, tracer=tracer)
    seconds = time.perf_counter() - t0
    cache.store(cache_dir, desc, image, seconds)
    return image, seconds, False


def model_setup(scene, objects, samples: int, cache_dir, progress):
    """The scene's size, the objects' interior mask and the CPU dipole model image (cached):
    (width, height, mask, model image, model seconds)."""
    width, height = extract.output_size(scene.render)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = extract.frame_inputs(depsgraph, extract.render_camera(depsgraph, width, height))
    tracer = BVHTracer(scene_triangles(frame)[0])
    mask = interior(_mask(frame, tracer, {ob.name for ob in objects}))
    model_image, model_seconds, _ = model_reference(frame, objects, tracer, samples,
                                                    scene_description(depsgraph, frame, objects), Path(cache_dir),
                                                    progress)
    return width, height, mask, model_image, model_seconds


def machine_description() -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), cpu)
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "system": platform.platform(), "python": platform.python_version()}
