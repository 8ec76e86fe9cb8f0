"""Properties: ``Object.translucent`` (material and method) and ``Scene.translucent``."""

import bpy

from .. import techniques
from ..core import quality
from ..core.physics.presets import USER_PREFIX, load_presets, load_user_presets
from . import preferences

_PRESET_ITEMS: list = []


def user_presets_path():
    """The user presets' JSON file in Blender's user configuration (created on first save)."""
    from pathlib import Path

    return Path(bpy.utils.user_resource("CONFIG", path="translucent")) / "presets.json"


def refresh_preset_items() -> None:
    """Rebuild the preset list (after a user preset is saved or removed). Blender keeps pointers into these
    strings: the list object stays the same and stays alive."""

    _PRESET_ITEMS.clear()
    _PRESET_ITEMS.append(("CUSTOM", "Custom", "Coefficients set by hand"))
    for name in sorted(load_presets()):
        _PRESET_ITEMS.append((name, name.capitalize(), f"Measured {name} (Jensen et al. 2001)"))
    for name in sorted(load_user_presets(user_presets_path())):
        _PRESET_ITEMS.append((USER_PREFIX + name, name, f"Your preset '{name}'"))


def _preset_items(self, context):
    if not _PRESET_ITEMS:
        refresh_preset_items()
    return _PRESET_ITEMS


def _preset_material(name: str):

    if name.startswith(USER_PREFIX):
        return load_user_presets(user_presets_path()).get(name[len(USER_PREFIX):])
    return load_presets().get(name)


_applying = [False]  # set while a preset writes its coefficients


def apply_preset(props, name: str) -> None:
    mat = _preset_material(name)
    if mat is None:
        return
    _applying[0] = True
    try:
        props.sigma_a = mat.sigma_a
        props.sigma_s_prime = mat.sigma_s_prime
        props.eta = mat.eta
        props.g = mat.g
    finally:
        _applying[0] = False


def _on_coefficients(self, context):
    """A coefficient edited by hand: the preset no longer describes the object, so it says Custom."""
    if _applying[0] or self.preset == "CUSTOM":
        return
    mat = _preset_material(self.preset)
    if mat is None:
        return
    same = all(abs(a - b) <= 1e-5 * max(1.0, abs(b)) for a, b in zip(
        (*self.sigma_a, *self.sigma_s_prime, self.eta, self.g), (*mat.sigma_a, *mat.sigma_s_prime, mat.eta, mat.g)))
    if not same:
        self.preset = "CUSTOM"


def _on_method(self, context):
    """A method chosen: its resolutions at the preferences' default quality."""

    prefs = preferences.get(context)
    if prefs is not None and prefs.default_quality != "STANDARD":
        quality.apply(self, quality.OBJECT, prefs.default_quality)


def _on_preset(self, context):
    apply_preset(self, self.preset)


def _method_property():
    """Object.translucent.method with the registry's methods; each keeps its number, which files store."""
    return bpy.props.EnumProperty(name="Method", description="How this object's translucency is rendered",
                                  items=techniques.method_items(), default="OFF", update=_on_method)


def refresh_methods() -> None:
    """Rebuild the method property after the registry changed (a technique registered at run time)."""
    TranslucentObjectSettings.method = _method_property()


class TranslucentObjectSettings(bpy.types.PropertyGroup):
    method: _method_property()
    preset: bpy.props.EnumProperty(
        name="Preset",
        description="Measured material coefficients (Jensen et al. 2001)",
        items=_preset_items,
        update=_on_preset,
    )
    sigma_a: bpy.props.FloatVectorProperty(
        name="Absorption (mm⁻¹)",
        description="Absorption coefficient sigma_a per RGB channel, in 1/mm",
        size=3, min=0.0, soft_max=2.0, precision=4, default=(0.0021, 0.0041, 0.0071), update=_on_coefficients,
    )
    sigma_s_prime: bpy.props.FloatVectorProperty(
        name="Reduced scattering (mm⁻¹)",
        description="Reduced scattering coefficient sigma_s' = (1 - g) sigma_s per RGB channel, in 1/mm",
        size=3, min=1e-6, soft_max=20.0, precision=3, default=(2.19, 2.62, 3.00), update=_on_coefficients,
    )
    eta: bpy.props.FloatProperty(
        name="IOR", description="Relative index of refraction eta", min=1.0, max=3.0, default=1.3,
        update=_on_coefficients,
    )
    g: bpy.props.FloatProperty(
        name="Anisotropy g", description="Mean cosine of the phase function", min=-0.99, max=0.99, default=0.0,
        update=_on_coefficients,
    )
    profile: bpy.props.EnumProperty(
        name="Profile",
        items=[("DIPOLE", "Dipole", "Homogeneous medium (Jensen 2001)"),
               ("MULTIPOLE", "Layer over base", "This medium as a layer over a base medium: multipole, "
                                                "Donner & Jensen 2005 (IMAGE_SPACE)")],
        default="DIPOLE",
    )
    layer_thickness: bpy.props.FloatProperty(
        name="Layer (mm)", description="Thickness of the layer over the base, in mm (at least one mean free path)",
        min=0.01, soft_max=20.0, default=1.0,
    )
    base_sigma_a: bpy.props.FloatVectorProperty(
        name="Base absorption (mm⁻¹)", size=3, min=0.0, soft_max=2.0, precision=4, default=(0.0021, 0.0041, 0.0071),
    )
    base_sigma_s_prime: bpy.props.FloatVectorProperty(
        name="Base reduced scattering (mm⁻¹)", size=3, min=1e-6, soft_max=20.0, precision=3, default=(2.19, 2.62, 3.0),
    )
    mm_per_unit: bpy.props.FloatProperty(
        name="mm per unit",
        description="Millimetres per Blender unit for this object (1 m = 1000 mm); sets the scale of scattering",
        min=1e-6, soft_max=1e5, default=1000.0,
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
        min=0.005, max=0.5, default=0.05, precision=3, step=0.5,
    )
    auto_summary: bpy.props.StringProperty(
        name="Auto choice", description="What Auto chose last, its predicted error and cost, and why",
        default="", options={"HIDDEN"},
    )
    atlas_resolution: bpy.props.IntProperty(
        name="Atlas texels",
        description="TEXTURE_SPACE: texels along the side of the texture atlas (Lensch used 512); the proxy "
                    "mesh follows it at Proxy spacing texels per edge. Changing it needs a new bake",
        min=64, max=4096, soft_max=2048, default=512,
    )
    proxy_spacing: bpy.props.FloatProperty(
        name="Proxy spacing",
        description="TEXTURE_SPACE: mean edge of the proxy mesh, in atlas texels. Finer follows shadow edges "
                    "more closely (back-lit bunny, atlas 512: 6.9 % from the dipole model at 3.5, 4.7 % at 2.4) "
                    "but bakes longer (44 s and 76 s here) and stores 3.4 times the form factors. "
                    "Changing it needs a new bake",
        min=1.5, max=8.0, default=3.5, precision=2,
    )
    texture_blending: bpy.props.BoolProperty(
        name="Blend local and global",
        description="TEXTURE_SPACE: Lensch Sec. 5.4, fit the direct radiosity B^d and correct the kernels; off "
                    "shows the paper's Fig. 6 artefact (light counted twice near where it enters)",
        default=True,
    )
    quadgraph_K: bpy.props.FloatProperty(
        name="Density K",
        description="QUADGRAPH: tetrahedron size as the paper's K (Wang 2010 Fig. 11-13); smaller is denser, "
                    "slower and more accurate (1: about 10 % error, 0.1: about 2 % in the paper). Changing it "
                    "needs a new bake",
        min=0.05, max=2.0, default=1.0, precision=2,
    )
    quadgraph_levels: bpy.props.IntProperty(
        name="Levels",
        description="QUADGRAPH: multi-resolution levels, each with about a quarter of the surface nodes of "
                    "the next (Wang 2010 Sec. 4.3); the solver starts on the coarsest",
        min=1, max=5, default=3,
    )
    veins: bpy.props.FloatProperty(
        name="Veins",
        description="QUADGRAPH: strength of procedural marble veins in the volume (more absorption and "
                    "scattering along noise veins, as Lensch's marble); 0 is homogeneous",
        min=0.0, max=1.0, default=0.0,
    )
    single_scattering: bpy.props.BoolProperty(
        name="Surface term",
        description="QUADGRAPH: draw the surface's own response to each light: light scattered once "
                    "(marched along the view ray through the light's distance map) and the multiple "
                    "scattering of a lit half-space (Chandrasekhar), where the diffusion alone is Lambertian "
                    "and leaves out the first order: the bright rims where a light grazes a back-lit object",
        default=True,
    )
    veins_scale: bpy.props.FloatProperty(
        name="Vein spacing (mm)", description="QUADGRAPH: distance between veins, in mm", min=0.1, default=20.0,
        unit="NONE",
    )
    geocube_resolution: bpy.props.IntProperty(
        name="Cube texels",
        description="GEOCUBE: texels along a cube face (Chan & Wang used 64); 0 chooses it from the object's "
                    "size on the scene camera's image at bake time. Changing it needs a new bake",
        min=0, max=256, default=0,
    )
    geocube_steps: bpy.props.IntProperty(
        name="Max steps",
        description="GEOCUBE: cap on the cone-propelled steps of a ray inside the object (Chan & Wang Sec. 4: "
                    "5 to 10 there); a ray that reaches it exits early at the last surface point it saw",
        min=1, max=256, default=32,
    )
    caustics_caster: bpy.props.EnumProperty(
        name="Caustics",
        description="Throw caustics onto the other objects (Shah ch. 5): every light with caustics on is "
                    "refracted or mirrored by this object; it still casts its shadow",
        items=(("NONE", "None", "Not a caustics caster (other casters' caustics land on it)"),
               ("REFRACTIVE", "Refractive", "Glass, water: light refracts through the surface"),
               ("REFLECTIVE", "Reflective", "Metal: light is mirrored off the surface")),
        default="NONE",
    )
    caustics_ior: bpy.props.FloatProperty(
        name="Caustics IOR", description="Index of refraction of a refractive caster", min=1.0, max=3.0,
        default=1.5,
    )
    caustics_surfaces: bpy.props.EnumProperty(
        name="Surfaces",
        description="Refraction at one surface (a water surface over the receivers) or at two (a solid: in "
                    "and out, through the back faces)",
        items=(("ONE", "One", "One refraction: the light stays in the medium down to the receiver"),
               ("TWO", "Two", "In through the front and out through the back faces (Wyman 2005)")),
        default="TWO",
    )
    caustics_color: bpy.props.FloatVectorProperty(
        name="Caustics colour",
        description="Refractive: the colour light takes after travelling Colour distance through the medium "
                    "(absorption, Shah Eq. 5.7); reflective: the mirror's reflectance",
        subtype="COLOR", size=3, min=0.0, max=1.0, default=(1.0, 1.0, 1.0),
    )
    caustics_distance: bpy.props.FloatProperty(
        name="Colour distance (mm)", description="Distance through the medium at which light has the caustics "
                                                 "colour, in mm", min=1e-3, soft_max=1000.0, default=50.0,
    )
    caustics_dispersion: bpy.props.FloatProperty(
        name="Dispersion",
        description="Spread of the index of refraction over the colour channels: red eta - d, green eta, blue "
                    "eta + d (Shah Fig. 5.13); 0 uses one index",
        min=0.0, max=0.2, default=0.0, precision=3,
    )
    grass: bpy.props.BoolProperty(
        name="Grass field",
        description="Grow a grass field on this mesh, drawn from a BTF (Shah ch. 4): the cost is set by pixels, "
                    "not blades. Add it with Add Grass Field; bake the BTF with Bake Grass BTF",
        default=False,
    )
    grass_tile: bpy.props.FloatProperty(
        name="Tile", description="Side of the square patch of grass the BTF repeats", subtype="DISTANCE",
        unit="LENGTH", min=1e-3, soft_max=10.0, default=0.1,
    )
    grass_blade_height: bpy.props.FloatProperty(
        name="Blade height", description="Height of the tallest blades (5-60 % of the tile)", subtype="DISTANCE",
        unit="LENGTH", min=1e-4, soft_max=1.0, default=0.045,
    )
    grass_blades: bpy.props.IntProperty(
        name="Blades per tile", description="Blades in one tile of the patch", min=1, max=5000, default=500,
    )
    grass_seed: bpy.props.IntProperty(name="Seed", description="Random layout of the blades", min=0, default=7)
    grass_resolution: bpy.props.EnumProperty(
        name="BTF texels", description="Texels per side of each of the 1,701 BTF images",
        items=(("64", "64", "Fast bake, soft blades"), ("128", "128", "As Shah"), ("256", "256", "Sharp, 4x the bake")),
        default="128",
    )
    grass_target_error: bpy.props.FloatProperty(
        name="Target error",
        description="Relative reconstruction error of the compressed BTF; sets how many eigen-textures are "
                    "kept (lower: sharper, more memory)",
        min=0.01, max=0.9, default=0.5, precision=2,
    )
    grass_lod: bpy.props.FloatProperty(
        name="Detail falloff",
        description="BTF texels per pixel beyond which fewer eigen-textures are summed (far grass is cheaper); "
                    "0 keeps all of them everywhere",
        min=0.0, soft_max=8.0, default=1.0,
    )

    relief: bpy.props.EnumProperty(
        name="Height field",
        description="Per-pixel displacement by a height map over the object's UVs (Shah ch. 3): occlusion, "
                    "self-shadowing and correct depth without extra geometry",
        items=(("OFF", "Off", "No height field"),
               ("INTERVAL", "Interval mapping", "Linear search, then interval (secant) refinement (Shah 2007)"),
               ("RELIEF", "Relief mapping", "Linear search, then binary search (Policarpo 2005), for comparison")),
        default="OFF",
    )
    relief_image: bpy.props.PointerProperty(
        name="Height map", type=bpy.types.Image,
        description="Image whose brightness is the height (white: the surface, black: the deepest point)",
    )
    relief_depth: bpy.props.FloatProperty(
        name="Depth", description="How deep the black of the height map lies under the surface",
        subtype="DISTANCE", unit="LENGTH", min=0.0, soft_max=0.2, default=0.02,
    )
    relief_linear_steps: bpy.props.IntProperty(
        name="Linear steps", description="Uniform steps that find the first interval the ray enters (Shah: 5)",
        min=2, max=64, default=8,
    )
    relief_iterations: bpy.props.IntProperty(
        name="Refinements", description="Most refinement steps after the linear search (Shah: 10)",
        min=1, max=32, default=10,
    )
    relief_shadows: bpy.props.BoolProperty(
        name="Self-shadowing", description="The height field shadows itself (a search toward each light)",
        default=True,
    )


class TranslucentLightSettings(bpy.types.PropertyGroup):
    caustics: bpy.props.BoolProperty(
        name="Caustics", description="Caustics casters refract or mirror this light (Translucent)", default=True,
    )


class TranslucentSceneSettings(bpy.types.PropertyGroup):
    shadow_resolution: bpy.props.IntProperty(
        name="Shadow resolution", description="Texels per shadow-map face", min=64, max=8192, default=1024
    )
    area_light_samples: bpy.props.IntProperty(
        name="Area light samples", description="Area lights are drawn as n x n point emitters", min=1, max=8,
        default=2,
    )
    splat_threshold: bpy.props.FloatProperty(
        name="Splat threshold",
        description="IMAGE_SPACE: share of the profile's energy beyond the splat radius (Shah Eq. 6.16)",
        min=1e-4, max=0.2, default=0.01, precision=3,
    )
    splat_overlap: bpy.props.FloatProperty(
        name="Splat overlap",
        description="IMAGE_SPACE: light-view samples per splat radius; more is smoother and slower",
        min=2.0, max=128.0, default=32.0,
    )
    splat_max_grid: bpy.props.IntProperty(
        name="Max samples per side",
        description="IMAGE_SPACE: light-view samples per face side, at most",
        min=16, max=4096, default=1024,
    )
    splat_world_layers: bpy.props.IntProperty(
        name="World layers",
        description="IMAGE_SPACE: depth-peeled layers per axis that receive world light, splatted like the "
                    "lights' samples (Shah 6.4.2); 0 takes the world over a locally flat surface (cheaper, "
                    "no light through thin parts)",
        min=0, max=16, default=4,
    )
    splat_world_overlap: bpy.props.FloatProperty(
        name="World overlap",
        description="IMAGE_SPACE: world samples per splat radius (fewer than the lights' suffice: world light is "
                    "smooth)",
        min=2.0, max=64.0, default=16.0,
    )
    temporal_coherence: bpy.props.BoolProperty(
        name="Temporal coherence",
        description="IMAGE_SPACE: reuse the previous frame's light samples to reduce flicker in animation and "
                    "in the viewport (Shah 6.5.2)",
        default=True,
    )
    texture_product: bpy.props.EnumProperty(
        name="Global product",
        description="TEXTURE_SPACE: where the sparse vertex-to-vertex product F^0 E runs (Lensch Eq. 11)",
        items=(("GPU", "GPU", "A fragment per vertex walks its row of the sparse matrix"),
               ("CPU", "CPU", "scipy.sparse after reading the vertex irradiance back")),
        default="GPU",
    )
    quadgraph_tolerance: bpy.props.FloatProperty(
        name="Solver tolerance",
        description="QUADGRAPH: a level's relaxation stops when one iteration changes the flux by less than "
                    "this (relative to its largest value; checked every 16 iterations), or at the cap. "
                    "The GPU holds the flux in 32-bit floats: 1e-6 is the smallest change it can resolve",
        min=1e-6, max=0.1, default=2e-5, precision=6,
    )
    quadgraph_iterations: bpy.props.IntProperty(
        name="Max iterations", description="QUADGRAPH: iteration cap per level", min=8, max=20000, default=1000,
    )
    geocube_output: bpy.props.IntProperty(
        name="GEOCUBE output", description="GEOCUBE pass output (tests, debugging): 0 colour, 1 entry point, "
                                           "2 exit point, 3 refracted direction (bake frame)",
        min=0, max=3, default=0, options={"HIDDEN"},
    )
    quadgraph_output: bpy.props.IntProperty(
        name="QUADGRAPH output", description="QUADGRAPH display output (tests, debugging): 0 colour, 1 the "
                                             "diffusion alone, 2 single scattering alone, 3 the local multiple "
                                             "scattering alone",
        min=0, max=3, default=0, options={"HIDDEN"},
    )
    relief_output: bpy.props.IntProperty(
        name="Height-field output", description="Height-field pass output (tests, debugging): 0 colour, 1 hit "
                                                "uv, depth and refinement count",
        min=0, max=1, default=0, options={"HIDDEN"},
    )
    capture_passes: bpy.props.BoolProperty(
        name="Capture passes", description="Keep read-backs of intermediate passes (tests, debugging)",
        default=False, options={"HIDDEN"},
    )
    caustics_grid: bpy.props.IntProperty(
        name="Caustics grid",
        description="Vertex grid per caster and light, per side (Shah used 128: 64 leaves gaps between fixed "
                    "splats, Fig. 5.11)", min=8, max=1024, default=128,
    )
    caustics_iterations: bpy.props.IntProperty(
        name="Iterations", description="Look-ups of the intersection estimate, through the caster's back faces "
                                       "and to the receivers (Shah 5.3.4: one for a flat floor, about five on "
                                       "rugged receivers; light leaving a ball near its rim needs 4 with Secant)",
        min=1, max=16, default=4,
    )
    caustics_guard: bpy.props.BoolProperty(
        name="Oscillation guard", description="Bisect once two estimates bracket the intersection (Shah 5.3.4)",
        default=True,
    )
    caustics_estimator: bpy.props.EnumProperty(
        name="Estimator",
        description="Root finding of the intersection estimate (Shah 5.3.4)",
        items=(("SECANT", "Secant", "Shah's first step, then secant steps through the last two estimates: "
                                    "converges in fewer look-ups where rays cross the surface obliquely"),
               ("SHAH", "Shah", "Shah's fixed-point step d = |y(v + d r) - v| every time")),
        default="SECANT",
    )
    caustics_map: bpy.props.IntProperty(
        name="Caustic map", description="Texels per face of the caustic and receiver maps", min=64, max=4096,
        default=1024,
    )
    caustics_splat: bpy.props.FloatProperty(
        name="Splat width", description="Gaussian splat sigma in caustic-map texels (the smallest one with "
                                        "adaptive splats)", min=0.5, max=16.0, default=1.0,
    )
    caustics_adaptive: bpy.props.BoolProperty(
        name="Adaptive splats", description="Widen each splat to the spacing of its neighbours' landing points: "
                                            "no gaps at coarse grids, sharp where light converges",
        default=True,
    )
    overlay_other_engines: bpy.props.BoolProperty(
        name="Draw in other engines",
        description="Draw objects with a translucency method over the viewport of other render engines",
        default=False,
    )


classes = (TranslucentObjectSettings, TranslucentLightSettings, TranslucentSceneSettings)


def register_pointers() -> None:
    techniques._listeners.append(refresh_methods)
    bpy.types.Object.translucent = bpy.props.PointerProperty(type=TranslucentObjectSettings)
    bpy.types.Scene.translucent = bpy.props.PointerProperty(type=TranslucentSceneSettings)
    bpy.types.Light.translucent = bpy.props.PointerProperty(type=TranslucentLightSettings)


def unregister_pointers() -> None:
    if refresh_methods in techniques._listeners:
        techniques._listeners.remove(refresh_methods)
    del bpy.types.Light.translucent
    del bpy.types.Scene.translucent
    del bpy.types.Object.translucent
