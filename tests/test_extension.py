"""The built zip installs with Blender's installer, and enabling/disabling leaves nothing behind."""
from __future__ import annotations

import os

import pytest

bpy = pytest.importorskip("bpy")

from conftest import ext_module  # noqa: E402

OUR_CLASSES = ("TranslucentRenderEngine", "TRANSLUCENT_OT_bake", "TRANSLUCENT_OT_clear_bake",
               "TRANSLUCENT_OT_bake_textures", "TRANSLUCENT_OT_bake_all", "TRANSLUCENT_OT_purge_bakes",
               "TRANSLUCENT_OT_add_demo_scene", "TRANSLUCENT_OT_compare_cycles", "TRANSLUCENT_OT_add_paint_layer",
               "TRANSLUCENT_OT_bake_grass_btf", "TRANSLUCENT_OT_add_grass_field", "TRANSLUCENT_OT_set_physical_size",
               "TRANSLUCENT_OT_apply_quality", "TRANSLUCENT_OT_auto_quality", "TRANSLUCENT_OT_save_preset",
               "TRANSLUCENT_OT_remove_preset", "TranslucentPreferences", "VIEW3D_PT_translucent_demo",
               "VIEW3D_PT_translucent_object",
               "VIEW3D_PT_translucent_scene", "TranslucentObjectSettings", "TranslucentSceneSettings",
               "TranslucentMaterialSettings", "MATERIAL_PT_translucent",
               "TranslucentLightSettings", "RENDER_PT_translucent", "RENDER_PT_translucent_image_space",
               "RENDER_PT_translucent_texture_space", "RENDER_PT_translucent_quadgraph_solver",
               "RENDER_PT_translucent_caustics", "RENDER_PT_translucent_last_frame", "OBJECT_PT_translucent",
               *(f"{parent}_{section}" for parent in ("VIEW3D_PT_translucent_object", "OBJECT_PT_translucent")
                 for section in ("medium", "quality", "bake", "caustics", "grass", "height_field", "paint")))
_CLASSES = ()


def _footprint():
    """Everything the extension adds to Blender that must disappear when it is disabled."""
    import bpy.types as T  # noqa: N812 - short for the many class lookups below

    draw_handler = __import__("sys").modules.get(f"{_PKG}.translucent_addon.blender.draw_handler")
    compat = [p.__name__ for p in T.Panel.__subclasses__()
              if "TRANSLUCENT_RT" in (getattr(p, "COMPAT_ENGINES", None) or set()) and p.is_registered]
    handlers = [h for h in (*bpy.app.handlers.save_pre, *bpy.app.handlers.save_post, *bpy.app.handlers.load_post)
                if getattr(h, "__module__", "").startswith(_PKG)]
    return {
        "classes": sorted(c.__name__ for c in _CLASSES if c.is_registered),
        "engine": _engine_selectable(),
        "object_prop": hasattr(T.Object, "translucent"),
        "material_prop": hasattr(T.Material, "translucent"),
        "scene_prop": hasattr(T.Scene, "translucent"),
        "light_prop": hasattr(T.Light, "translucent"),
        "operators": "bake" in dir(bpy.ops.translucent),
        "draw_handler": bool(draw_handler and draw_handler.is_registered()),
        "compat_panels": len(compat) > 0,
        # bake files: save_pre, save_post, load_post; settings: load_post; versioning: save_pre, load_post;
        # the session: load_post
        "handlers": len(handlers) == 7,
    }


_PKG = None


def _engine_selectable() -> bool:
    render = bpy.context.scene.render
    before = render.engine
    try:
        render.engine = "TRANSLUCENT_RT"
    except TypeError:
        return False
    render.engine = before
    return True


def test_enable_disable_three_times_leaves_nothing(installed):
    global _PKG, _CLASSES
    _PKG = installed
    _CLASSES = __import__("importlib").import_module(installed)._classes
    on = _footprint()
    assert on["classes"] == sorted(OUR_CLASSES)
    assert all(on.values()), on
    for _ in range(3):
        bpy.ops.preferences.addon_disable(module=installed)
        off = _footprint()
        assert off == {"classes": [], "engine": False, "object_prop": False, "material_prop": False,
                       "scene_prop": False,
                       "light_prop": False, "operators": False, "draw_handler": False, "compat_panels": False,
                       "handlers": False}, off
        bpy.ops.preferences.addon_enable(module=installed)
        assert _footprint() == on


def test_bundled_moderngl_wheel_gives_a_standalone_context(installed):
    """The bake GPU: moderngl from the zip's wheels, on a headless EGL context (llvmpipe here). The test
    environment has its own moderngl (pure BTF tests), so the bundled copy runs in a child interpreter
    with the extensions' site-packages first."""
    _run_with_bundled_wheels(
        "import numpy as np, moderngl; "
        "ctx = moderngl.create_standalone_context(backend='egl'); "
        "assert ctx.version_code >= 430, ctx.version_code; "  # compute shaders for bakes
        "prog = ctx.compute_shader('#version 430\\nlayout(local_size_x=64) in;\\n"
        "layout(std430, binding=0) buffer B { float v[]; };\\n"
        "void main(){ uint i = gl_GlobalInvocationID.x; v[i] = float(i) * 2.0; }'); "
        "buf = ctx.buffer(reserve=256 * 4); buf.bind_to_storage_buffer(0); prog.run(4); "
        "assert np.frombuffer(buf.read(), np.float32)[255] == 510.0; ctx.release(); "
        "print(moderngl.__file__)")


def test_bundled_xatlas_wheel_imports(installed):
    """xatlas (lightmap UVs) from the zip's wheels. The test environment has its own xatlas
    earlier on sys.path, so the bundled copy is imported in a child interpreter with the
    extensions' site-packages first, as in a Blender without that environment."""
    _run_with_bundled_wheels(
        "import numpy as np, xatlas; "
        "v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32); "
        "f = np.array([[0, 1, 2], [0, 2, 3]], np.uint32); "
        "vmap, idx, uvs = xatlas.parametrize(v, f); "
        "assert idx.shape == (2, 3) and uvs.shape[1] == 2, (idx.shape, uvs.shape); print(xatlas.__file__)")


def _run_with_bundled_wheels(code: str) -> None:
    """Run ``code`` in a child interpreter with the extensions' site-packages first on sys.path; it must
    succeed and print the path of the module it tested, which must come from those site-packages."""
    import subprocess
    import sys

    sites = [p for p in sys.path
             if f"{os.sep}.local{os.sep}" in p and "extensions" in p and p.endswith("site-packages")]
    assert sites, sys.path
    code = "import sys; sys.path.insert(0, sys.argv[1]); " + code
    out = subprocess.run([sys.executable, "-I", "-c", code, sites[0]], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().startswith(sites[0]), out.stdout


def test_render_engine_and_properties_are_there(tr, scene):
    assert scene.render.engine == "TRANSLUCENT_RT"
    methods = ext_module(tr, "translucent_addon.techniques")
    ob = bpy.data.objects.new("Empty", None)
    items = [i.identifier for i in ob.translucent.bl_rna.properties["method"].enum_items]
    assert tuple(items) == methods.method_ids()
    assert scene.translucent.shadow_resolution == 1024


def test_bundled_scipy_wheel_imports(installed):
    """SciPy (the bakes' sparse solvers and k-d trees, GEOCUBE's world and slab tables) from the zip's
    wheels: Blender ships none."""
    _run_with_bundled_wheels(
        "import numpy as np, scipy; "
        "from scipy.spatial import cKDTree; from scipy.sparse import csc_matrix; "
        "from scipy.sparse.linalg import splu; "
        "d, i = cKDTree(np.eye(3)).query([[0.9, 0.0, 0.0]]); assert i[0] == 0; "
        "x = splu(csc_matrix(2.0 * np.eye(3))).solve(np.ones(3)); assert np.allclose(x, 0.5); "
        "print(scipy.__file__)")
