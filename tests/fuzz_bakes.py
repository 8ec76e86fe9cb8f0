"""The bake reader under seeded random damage (issue 37, point 5), run in a child Blender by test_bake_fuzz.py.

    python fuzz_bakes.py SCRIPTS_DIR SEED CASES_PER_METHOD

Bakes a TEXTURE_SPACE, a QUADGRAPH and a GEOCUBE ball beside an opaque ground, then for each case damages one
stored array of one bake (values, length, shape, dtype, missing, meta, another array's data), usually writing
the data hash again so that the reader's own checks are what stands between the damage and SciPy or the GPU,
and renders a frame in batch. It prints one line of JSON per case before drawing ("case") and one after
("result": "drawn" with finite pixels, or "refused" with the message); anything else, a crash or a hang, is
for the parent to see.
"""
import json
import sys

sys.path.insert(0, sys.argv[1])
import blender_env  # noqa: E402

PACKAGE = blender_env.start()

import importlib  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

store = importlib.import_module(PACKAGE + ".translucent_addon.core.bake_store")
bake_cache = importlib.import_module(PACKAGE + ".translucent_addon.gpu.bake_cache")
render_pixels = importlib.import_module(PACKAGE + ".translucent_addon.blender.compare_runner").render_pixels
METHODS = {"TEXTURE_SPACE": dict(atlas_resolution=64), "QUADGRAPH": dict(quadgraph_levels=1, quadgraph_K=0.5),
           "GEOCUBE": dict(geocube_resolution=16)}
INTS = (2_000_000_000, -2_000_000_000, -1, 2**31 - 1, 0, 7)
FLOATS = (np.nan, np.inf, -np.inf, 1e30, -1e30, 0.0, -1.0, 3.0e38)
DTYPES = ("<f4", "<f8", "<i4", "<f2", "|u1", "bogus")


def scene_with_bakes():
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "TRANSLUCENT_RT"
    scene.translucent.bake_storage = "PACKED"  # the arrays in the ID, where the cases damage them
    bpy.ops.mesh.primitive_plane_add(size=8.0)
    bpy.ops.object.light_add(type="SUN", location=(2, -2, 4))
    bpy.ops.object.camera_add(location=(0, -7, 3), rotation=(1.2, 0, 0))
    scene.camera = bpy.context.object
    balls = {}
    for k, (method, settings) in enumerate(METHODS.items()):
        bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=0.7, location=(2.0 * k - 2.0, 0, 0.8))
        ball = bpy.context.object
        ball.name = method
        ball.translucent.method = method
        ball.translucent.mm_per_unit = 20.0
        for name, value in settings.items():
            setattr(ball.translucent, name, value)
        assert bpy.ops.translucent.bake() == {"FINISHED"}, method
        balls[method] = ball
    return scene, balls


def snapshot(ball, method):
    g = ball.data["translucent_bake"][method]
    return {"arrays": {n: np.array(g["arrays"][n]) for n in g["arrays"].keys()},
            "shapes": {n: list(g["shapes"][n]) for n in g["shapes"].keys()},
            "dtypes": {n: str(g["dtypes"][n]) for n in g["dtypes"].keys()},
            "meta": str(g["meta"]), "data_hash": str(g["data_hash"])}


def restore(ball, method, saved):
    g = ball.data["translucent_bake"][method]
    for part in ("arrays", "shapes", "dtypes"):
        del g[part]
        g[part] = saved[part]
    g["meta"], g["data_hash"] = saved["meta"], saved["data_hash"]


def damage(rng, ball, method, saved):
    """Damage one array (or the meta) of the stored bake; returns a description."""
    g = ball.data["translucent_bake"][method]
    names = sorted(saved["arrays"])
    name = names[rng.integers(len(names))]
    a = saved["arrays"][name].copy()
    kind = ["values", "values", "values", "truncate", "extend", "shape", "dtype", "drop", "meta", "swap"][
        rng.integers(10)]
    if kind == "values" and a.size:
        at = rng.integers(a.size, size=int(rng.integers(1, 4)))
        pool = INTS if a.dtype.kind == "i" else FLOATS
        a.reshape(-1)[at] = pool[rng.integers(len(pool))]
    elif kind == "truncate" and a.size:
        a = a[:int(rng.integers(a.size))]
    elif kind == "extend":
        a = np.concatenate([a, a[:int(rng.integers(1, 9))] if a.size else np.ones(3, a.dtype)])
    elif kind == "shape":
        shape = list(saved["shapes"][name]) or [1]
        shape[int(rng.integers(len(shape)))] *= int(rng.choice([0, 2, 1000]))
        g["shapes"][name] = shape
    elif kind == "dtype":
        g["dtypes"][name] = DTYPES[rng.integers(len(DTYPES))]
    elif kind == "drop":
        del g["arrays"][name]
    elif kind == "meta":
        g["meta"] = ["{not json", "[]", "{}", '{"levels": -1}'][rng.integers(4)]
    elif kind == "swap":
        other = names[rng.integers(len(names))]
        a = saved["arrays"][other][:a.size].copy() if saved["arrays"][other].dtype == a.dtype else a
    if kind not in ("drop", "shape", "dtype", "meta"):
        del g["arrays"][name]  # (assigning a shorter array in place keeps the old length)
        g["arrays"][name] = a
    rehash = rng.random() < 0.8  # as a script that knows the format would leave it: the hash agrees
    if rehash:
        try:
            stored = {n: store._stored(g["arrays"][n], g["dtypes"][n]) for n in g["arrays"].keys()}
            g["data_hash"] = store.data_hash(stored, {n: list(g["shapes"][n]) for n in stored},
                                             {n: str(g["dtypes"][n]) for n in stored}, str(g["meta"]),
                                             str(g["inputs_hash"]))
        except (TypeError, ValueError, KeyError):
            rehash = False
    return f"{kind} {name}" + (" (hash rewritten)" if rehash else "")


def render(scene):
    """'drawn' with the pixels' finiteness checked, or 'refused' with the message; anything else raises."""
    try:
        px = render_pixels(scene, 32, 32)[0]
    except RuntimeError as err:
        text = str(err)
        if "lost 1 object(s): '" in text and "ress Bake" in text:  # one object refused, with what to do
            return "refused", text.strip().splitlines()[-1]
        raise
    if not np.isfinite(px).all():
        raise AssertionError("non-finite pixels")
    return "drawn", ""


def main():
    seed, cases = int(sys.argv[2]), int(sys.argv[3])
    scene, balls = scene_with_bakes()
    assert render(scene)[0] == "drawn"
    rng = np.random.default_rng(seed)
    for method, ball in balls.items():
        saved = snapshot(ball, method)
        for case in range(cases):
            what = damage(rng, ball, method, saved)
            print(json.dumps({"case": case, "method": method, "damage": what}), flush=True)
            bake_cache.clear()  # as after opening the file
            result, message = render(scene)
            print(json.dumps({"case": case, "method": method, "damage": what, "result": result,
                              "message": message}), flush=True)
            restore(ball, method, saved)
    print(json.dumps({"done": True}), flush=True)


main()
