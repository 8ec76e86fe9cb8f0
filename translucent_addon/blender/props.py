"""Properties: ``Object.translucent`` (method, quality, its own medium), ``Material.translucent`` (the medium its
objects share), ``Scene.translucent`` and ``Light.translucent``."""

import shutil
import zlib
from pathlib import Path

import bpy

from .. import techniques
from ..core import quality
from ..core.physics.presets import USER_PREFIX, load_presets, load_user_presets
from ..core.properties import Prop
from ..techniques import registry as bake_registry
from . import medium_source, preferences
from .session import current as current_session


def _old_presets_path() -> Path:
    """Where user presets were kept up to 0.2.0: Blender's user configuration."""
    return Path(bpy.utils.user_resource("CONFIG", path="translucent")) / "presets.json"


def user_presets_path() -> Path:
    """The user presets' JSON file (created on first save) in the extension's own user folder, which Blender keeps
    for it across updates (``bpy.utils.extension_path_user``; Blender's configuration folder when enabled as a
    legacy add-on). A file in the old place is moved there once, with one console line."""
    try:
        path = Path(bpy.utils.extension_path_user(preferences.ROOT_PACKAGE, create=True)) / "presets.json"
    except ValueError:  # not an extension: no folder of its own
        return _old_presets_path()
    old = _old_presets_path()
    if not path.exists() and old.is_file():
        try:
            shutil.move(old, path)
            print(f"Translucent: user presets moved from {old} to the extension's own folder {path}", flush=True)
        except OSError as err:
            print(f"Translucent: user presets stay in {old}: they could not be moved ({err})", flush=True)
            return old
    return path


USER_PRESET_NUMBERS = 1 << 16  # user presets' enum numbers start here: 0 Custom, 1-12 the measured ones


def user_preset_number(name: str) -> int:
    """The number a user preset is stored as in files: from its name, so that saving or removing another
    preset does not change which one an object shows (a list position did)."""
    return USER_PRESET_NUMBERS + zlib.crc32(name.encode()) % (2**31 - 1 - USER_PRESET_NUMBERS)


def refresh_preset_items() -> None:
    """Rebuild the preset list (after a user preset is saved or removed). Blender keeps pointers into these
    strings: the list object (the session's ``preset_items``) stays the same and stays alive. Each item keeps its
    number (files store it)."""
    session = current_session()
    items = session.preset_items
    items.clear()
    items.append(("CUSTOM", "Custom", "Coefficients set by hand", 0))
    for number, name in enumerate(sorted(load_presets()), start=1):
        items.append((name, name.capitalize(), f"The absorption and scattering measured for real {name}", number))
    problems: list[str] = []
    for name in sorted(load_user_presets(user_presets_path(), problems)):
        items.append((USER_PREFIX + name, name, f"Your preset '{name}'", user_preset_number(name)))
    if problems != session.preset_problems:
        for line in problems:
            print(f"Translucent: {line}")
    session.preset_problems[:] = problems


def preset_problems() -> list[str]:
    """What the user presets file's last reading skipped (the object panel shows it)."""
    return current_session().preset_problems


def _preset_items(self, context):
    items = current_session().preset_items
    if not items:
        refresh_preset_items()
    return items


def _preset_material(name: str):

    if name.startswith(USER_PREFIX):
        return load_user_presets(user_presets_path()).get(name[len(USER_PREFIX):])
    return load_presets().get(name)


def apply_preset(props, name: str) -> None:
    mat = _preset_material(name)
    if mat is None:
        return
    session = current_session()
    session.applying_preset = True  # the coefficients below do not turn the preset to Custom one by one
    try:
        props.sigma_a = mat.sigma_a
        props.sigma_s_prime = mat.sigma_s_prime
        props.eta = mat.eta
        props.g = mat.g
    finally:
        session.applying_preset = False


def _on_coefficients(self, context):
    """A coefficient edited by hand: the preset no longer describes the object, so it says Custom."""
    if current_session().applying_preset or self.preset == "CUSTOM":
        return
    mat = _preset_material(self.preset)
    if mat is None:
        return
    same = all(abs(a - b) <= 1e-5 * max(1.0, abs(b)) for a, b in zip(
        (*self.sigma_a, *self.sigma_s_prime, self.eta, self.g), (*mat.sigma_a, *mat.sigma_s_prime, mat.eta, mat.g)))
    if not same:
        self.preset = "CUSTOM"


def _forget_auto_choice(self, context):
    """What Auto chose last no longer answers the setting just changed: the panel says it will choose again."""
    self.auto_summary = ""


def _on_method(self, context):
    """A method chosen: its resolutions at the preferences' default quality (Auto's last choice was another
    method's)."""
    _forget_auto_choice(self, context)

    prefs = preferences.get(context)
    if prefs is not None and prefs.default_quality != "STANDARD":
        quality.apply(self, techniques.tier_table("object"), prefs.default_quality)


def _on_preset(self, context):
    apply_preset(self, self.preset)


def _method_property():
    """Object.translucent.method with the registry's methods; each keeps its number, which files store."""
    return bpy.props.EnumProperty(name="Method", description="How this object's translucency is rendered",
                                  items=techniques.method_items(), default="OFF", update=_on_method)


def _instance_method_property():
    """Scene.translucent.instance_method: what draws geometry made by geometry nodes that no object holds (its
    material's medium); only methods that need no bake, which such geometry cannot have."""
    items = [i for i in techniques.method_items() if not bake_registry.needs_bake(i[0])]
    default = items[1][0] if len(items) > 1 else items[0][0]  # the first such method (by its number), else OFF
    return bpy.props.EnumProperty(
        name="Generated geometry", items=items, default=default,
        description="How instances of geometry that geometry nodes made (no object of yours holds it) are drawn "
                    "when their material has a subsurface medium. Instances of an object are drawn with that "
                    "object's method")


def refresh_methods() -> None:
    """Rebuild the method property after the registry changed (a technique registered at run time), and bring
    the technique's own properties (or take an unregistered one's away)."""
    TranslucentObjectSettings.method = _method_property()
    TranslucentSceneSettings.instance_method = _instance_method_property()
    _sync_technique_properties()


def _get_mm_per_unit(self) -> float:
    return medium_source.mm_per_unit(self)


def _set_mm_per_unit(self, value: float) -> None:
    self.scattering_scale = medium_source.unit_mm(bpy.context.scene) / value


def _medium_properties() -> dict:
    """The medium's settings, on the Material (shared by its objects) and on the Object (its own, when it has
    no material or its material leaves the medium to it): ``medium_source`` says which holds."""
    return dict(
        preset=bpy.props.EnumProperty(name="Preset", description="Measured real materials (marble, skin, milk, "
                                                                 "ketchup...), or your own saved presets",
                                      items=_preset_items, update=_on_preset),
        sigma_a=bpy.props.FloatVectorProperty(
            name="Absorption (mm⁻¹)", description="How strongly the material absorbs light, per colour channel, per "
                                                  "millimetre: higher is darker and more saturated",
            size=3, min=0.0, soft_max=2.0, precision=4, default=(0.0021, 0.0041, 0.0071), update=_on_coefficients),
        sigma_s_prime=bpy.props.FloatVectorProperty(
            name="Reduced scattering (mm⁻¹)",
            description="How often light changes direction, per colour channel, per millimetre: higher keeps light "
                        "nearer where it enters",
            size=3, min=1e-6, soft_max=20.0, precision=3, default=(2.19, 2.62, 3.00), update=_on_coefficients),
        eta=bpy.props.FloatProperty(name="IOR", description="Relative index of refraction eta",
                                    min=medium_source.ETA_RANGE[0], max=medium_source.ETA_RANGE[1], default=1.3,
                                    update=_on_coefficients),
        g=bpy.props.FloatProperty(name="Anisotropy g", description="Mean cosine of the phase function",
                                  min=medium_source.G_RANGE[0], max=medium_source.G_RANGE[1], default=0.0,
                                  update=_on_coefficients),
        profile=bpy.props.EnumProperty(
            name="Profile", description="Radial profile of the light that scatters under the surface",
            # Numbered: files store the number, and EXACT came after the other two.
            items=[("EXACT", "Exact", "Homogeneous medium, profile of exact transport (half-space Monte Carlo)", 2),
                   ("DIPOLE", "Dipole", "One uniform material throughout", 0),
                   ("MULTIPOLE", "Layer over base", "This material as a thin layer over a base material: Image Space "
                                                    "draws both, the other methods the layer alone",
                    1)],
            default="EXACT"),
        layer_thickness=bpy.props.FloatProperty(
            name="Layer", description="Thickness of the layer over the base (at least one mean free path)",
            subtype="DISTANCE", unit="LENGTH", min=1e-5, soft_max=0.02, default=0.001, precision=4),
        base_sigma_a=bpy.props.FloatVectorProperty(
            name="Base absorption (mm⁻¹)", size=3, min=0.0, soft_max=2.0, precision=4,
            default=(0.0021, 0.0041, 0.0071),
            description="Absorption coefficient of the medium under the layer, per RGB channel"),
        base_sigma_s_prime=bpy.props.FloatVectorProperty(
            name="Base reduced scattering (mm⁻¹)", size=3, min=1e-6, soft_max=20.0, precision=3,
            default=(2.19, 2.62, 3.0),
            description="Reduced scattering coefficient of the medium under the layer, per RGB channel"),
    )


MEDIUM_SOURCES = (
    ("PRINCIPLED", "From Principled BSDF", "Converted from the Principled BSDF's subsurface inputs as Cycles "
                                           "renders them: nothing to set for a Cycles material", 0),
    ("MATERIAL", "Coefficients", "A measured preset or coefficients set here, shared by every object with this "
                                 "material", 1),
    ("OBJECT", "Per object", "Each object's own coefficients (Object properties); how files from 0.1 keep "
                             "their media", 2),
)


class TranslucentMaterialSettings(bpy.types.PropertyGroup):
    """A material's medium: where it comes from and, for Coefficients, the coefficients."""

    source: bpy.props.EnumProperty(name="Medium", description="Where the medium of objects with this material "
                                                              "comes from", items=MEDIUM_SOURCES,
                                   default="PRINCIPLED")


class TranslucentObjectSettings(bpy.types.PropertyGroup):
    method: _method_property()
    scattering_scale: bpy.props.FloatProperty(
        name="Scattering scale",
        description="Multiplies how far light scatters in this object, as Cycles' Subsurface Scale does: 2 scatters "
                    "as an object of half the size",
        min=1e-6, soft_min=0.01, soft_max=100.0, default=1.0,
    )
    mm_per_unit: bpy.props.FloatProperty(
        name="mm per unit", description="Millimetres of the medium per Blender unit: the scene's unit over the "
                                        "scattering scale (for scripts; the scale is what is stored)",
        min=1e-9, get=_get_mm_per_unit, set=_set_mm_per_unit, options={"HIDDEN"},
    )
    quality: bpy.props.EnumProperty(
        name="Quality",
        description="How this object's resolutions are set",
        items=[("MANUAL", "Manual", "The resolutions below, as you set them (or a tier from Apply Quality)"),
               ("AUTO", "Auto", "Chosen at each bake (and by Choose Resolutions) to reach the target error at the "
                                "least cost, from the material's scattering length, the object's size on the "
                                "camera's image and the benchmark's measured curves")],
        default="MANUAL",
    )
    target_error: bpy.props.FloatProperty(
        name="Target error",
        description="Auto: the discretisation error to reach, relative RMSE against the method's own model "
                    "(0.05: 5 %)",
        min=0.005, max=0.5, default=0.05, precision=3, step=0.5, update=_forget_auto_choice,
    )
    auto_summary: bpy.props.StringProperty(
        name="Auto choice", description="What Auto chose last, its predicted error and cost, and why",
        default="", options={"HIDDEN"},
    )



class TranslucentLightSettings(bpy.types.PropertyGroup):
    """A light's settings: the techniques' (caustics) join below."""


class TranslucentSceneSettings(bpy.types.PropertyGroup):
    shadow_resolution: bpy.props.IntProperty(
        name="Shadow resolution", description="Texels per shadow-map face", min=64, max=8192, default=1024
    )
    area_light_samples: bpy.props.IntProperty(
        name="Area light samples", description="Area lights are drawn as n x n point emitters", min=1, max=8,
        default=2,
    )
    file_version: bpy.props.IntProperty(
        name="File version",
        description="The extension's file layout this file is in (stamped on opening, enabling and saving)",
        default=0, options={"HIDDEN"},
    )
    capture_passes: bpy.props.BoolProperty(
        name="Capture passes", description="Keep read-backs of intermediate passes (tests, debugging)",
        default=False, options={"HIDDEN"},
    )
    bake_storage: bpy.props.EnumProperty(
        name="Bake storage",
        description="Where new bakes keep their arrays",
        items=(("SIDECAR", "Beside the .blend", "In image files in a folder next to the .blend (<name>_translucent): "
                                                 "a small .blend, light undo; File > External Data > Pack Resources "
                                                 "packs them, and farm packers carry them", 0),
               ("PACKED", "In the .blend", "Inside the .blend, one file to hand on; a Texture Space bake can add "
                                           "100 MB, for every copy", 1)),
        default="SIDECAR",
    )
    fail_on_lost_objects: bpy.props.BoolProperty(
        name="Fail on undrawable objects",
        description="In a batch render (blender -b), a frame with an object that cannot be drawn as the file asks "
                    "(a damaged bake, vertices that are not numbers) is an error and is not written",
        default=True,
    )
    light_passes: bpy.props.BoolProperty(
        name="Light passes",
        description="Also write Subsurface (translucent objects' light below their gloss), Specular (every "
                    "material's gloss) and Diffuse (the rest) passes, which add up to Combined",
        default=False,
    )
    instance_method: _instance_method_property()
    overlay_other_engines: bpy.props.BoolProperty(
        name="Draw in other engines",
        description="Draw objects with a translucency method over the viewport of other render engines",
        default=False,
    )


for _group in (TranslucentObjectSettings, TranslucentMaterialSettings):
    _group.__annotations__.update(_medium_properties())

classes = (TranslucentObjectSettings, TranslucentMaterialSettings, TranslucentLightSettings,
           TranslucentSceneSettings)


def _bpy_property(p: Prop):
    """The bpy property a technique's declaration describes (``core.properties.Prop``)."""
    if p.kind == "ImagePointer":
        return bpy.props.PointerProperty(type=bpy.types.Image, **p.options)
    return getattr(bpy.props, p.kind)(**p.options)


_TECHNIQUE_GROUPS = ((TranslucentObjectSettings, "object_props"), (TranslucentSceneSettings, "scene_props"),
                     (TranslucentLightSettings, "light_props"))


def _join_technique_properties() -> None:
    """Each technique's own settings join the property groups before registration (``Technique.object_props``,
    ``scene_props``, ``light_props``): the groups above hold only what every object, scene and light shares."""
    for group, attr in _TECHNIQUE_GROUPS:
        for technique in techniques.REGISTRY:
            for p in getattr(technique, attr):
                group.__annotations__[p.name] = _bpy_property(p)


_join_technique_properties()


def _sync_technique_properties() -> None:
    """The property groups after the registry changed: a property a registered technique declares that the group
    lacks is added; one the group gained at run time that no technique declares now is removed."""
    base = set(bpy.types.PropertyGroup.bl_rna.properties.keys())
    for group, attr in _TECHNIQUE_GROUPS:
        declared = {p.name: p for technique in techniques.REGISTRY for p in getattr(technique, attr)}
        present = set(group.bl_rna.properties.keys())
        for name, p in declared.items():
            if name not in present:
                setattr(group, name, _bpy_property(p))
        for name in present - set(declared) - set(group.__annotations__) - base:
            delattr(group, name)


def bounded(group, name: str):
    """A setting as a frame may use it: an integer that a file or a script stored outside its range (an ID
    property is not asked for its range) clamped into it. Counts, steps and resolutions reach GPU loops and
    allocations: a stored 2^31 - 1 steps would hold the GPU until the driver resets it (issue 37)."""
    value = getattr(group, name)
    prop = group.bl_rna.properties[name]
    if prop.type == "INT" and not prop.is_array:
        return min(max(value, prop.hard_min), prop.hard_max)
    return value


def _groups():
    for collection, label in ((bpy.data.objects, "object"), (bpy.data.materials, "material"),
                              (bpy.data.scenes, "scene"), (bpy.data.lights, "light")):
        for idblock in collection:
            group = getattr(idblock, "translucent", None)
            if group is not None and idblock.library is None:  # linked data is the library's to fix
                yield f"{label} '{idblock.name}'", group


@bpy.app.handlers.persistent
def clamp_loaded_settings(*_args) -> None:
    """load_post: integers the opened file holds outside their range are set into it, each said in one line."""
    for where, group in _groups():
        for prop in group.bl_rna.properties:
            if prop.type != "INT" or prop.is_array or prop.identifier not in group:
                continue
            value = getattr(group, prop.identifier)
            kept = min(max(value, prop.hard_min), prop.hard_max)
            if kept != value:
                setattr(group, prop.identifier, kept)
                print(f"Translucent: {where}: {prop.name} was {value}, outside {prop.hard_min}-{prop.hard_max}; "
                      f"set to {kept}")


def register_pointers() -> None:
    techniques.REGISTRY.listeners.append(refresh_methods)
    bpy.types.Object.translucent = bpy.props.PointerProperty(type=TranslucentObjectSettings)
    bpy.types.Material.translucent = bpy.props.PointerProperty(type=TranslucentMaterialSettings)
    bpy.types.Scene.translucent = bpy.props.PointerProperty(type=TranslucentSceneSettings)
    bpy.types.Light.translucent = bpy.props.PointerProperty(type=TranslucentLightSettings)
    if clamp_loaded_settings not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(clamp_loaded_settings)


def unregister_pointers() -> None:
    if refresh_methods in techniques.REGISTRY.listeners:
        techniques.REGISTRY.listeners.remove(refresh_methods)
    if clamp_loaded_settings in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(clamp_loaded_settings)
    del bpy.types.Light.translucent
    del bpy.types.Scene.translucent
    del bpy.types.Material.translucent
    del bpy.types.Object.translucent
