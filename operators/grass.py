"""translucent.bake_grass_btf and translucent.add_grass_field (Shah ch. 4).

The BTF bake renders the procedural patch under 81 views and 21 lights and compresses it; it is
kept with the ground's mesh (``blender/bake_files.py``). Add Grass Field turns the field on for the
selected mesh and bakes its BTF when there is no current one.
"""

import time

import bpy

from ..translucent_addon.blender import bake_files
from ..translucent_addon.blender.extract import grass_status
from ..translucent_addon.techniques.grass import bake as grass_btf
from . import polls
from .bake import ModalJob, _active_mesh


def _ground(context):
    """The active mesh if it can carry grass, else None (having said why)."""
    ob, error = _active_mesh(context)
    if error is None and len(ob.data.polygons) == 0:
        error = f"'{ob.name}' has no faces to grow grass on"
    return ob, error


class TRANSLUCENT_OT_bake_grass_btf(ModalJob, bpy.types.Operator):
    """Render the active object's grass patch under 81 views and 21 lights and compress it into a BTF"""

    bl_idname = "translucent.bake_grass_btf"
    bl_label = "Bake Grass BTF"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return polls.idle(cls, ModalJob.running) and polls.ground(cls, context)
    _title = "Translucent grass BTF"

    def _prepare(self, context):
        ob, error = _ground(context)
        if error:
            self.report({"ERROR"}, error)
            return None
        s = ob.translucent
        try:
            params = grass_btf.params_from_settings(s.grass_tile, s.grass_blade_height, s.grass_blades,
                                                    s.grass_seed)
        except grass_btf.GrassSettingsError as err:
            self.report({"ERROR"}, f"'{ob.name}': {err}")
            return None
        return ob, (params, int(s.grass_resolution), float(s.grass_target_error))

    def _job_for(self, inputs):
        return grass_btf.bake(*inputs)

    def _finish(self, ob, inputs, result):
        arrays, meta = result
        meta["seconds"] = round(time.perf_counter() - self._t0, 3)
        why = bake_files.write(ob, grass_btf.BAKE_KEY, grass_btf.settings_hash(*inputs), arrays, meta,
                               bpy.context.scene)
        if why:
            self.report({"WARNING"}, why)
        ob.translucent.grass = True
        mb = meta["storage"]["total"] / 2**20
        if not meta["target_met"]:
            self.report({"WARNING"}, f"'{ob.name}': the target error {inputs[2]:.2f} is out of reach; kept "
                                     f"the most eigen-textures, error {meta['total_error']:.2f}")
        self.report({"INFO"}, f"'{ob.name}': grass BTF baked in {meta['seconds']:.1f} s "
                              f"({meta['counts'][0]} + 2 x {meta['counts'][1]} eigen-textures, {mb:.1f} MB)")


class TRANSLUCENT_OT_add_grass_field(bpy.types.Operator):
    """Grow a grass field on the selected mesh (a BTF layer over it) and bake its BTF if needed"""

    bl_idname = "translucent.add_grass_field"
    bl_label = "Add Grass Field"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return polls.ground(cls, context)

    def execute(self, context):
        return self._run(context, "EXEC_DEFAULT")

    def invoke(self, context, event):
        return self._run(context, "INVOKE_DEFAULT")

    def _run(self, context, how):
        ob, error = _ground(context)
        if error:
            self.report({"ERROR"}, error)
            return {"CANCELLED"}
        normals = [p.normal.z for p in ob.data.polygons[:1000]]
        if max(normals) <= 0.0:
            self.report({"WARNING"}, f"'{ob.name}': no face points up (+Z in object space); grass grows "
                                     f"along the normals, so it grows downward here")
        status, detail = grass_status(ob)
        if status == "INVALID":
            self.report({"ERROR"}, f"'{ob.name}': {detail}")
            return {"CANCELLED"}
        if status == "OK":
            ob.translucent.grass = True
            self.report({"INFO"}, f"'{ob.name}': grass field on (its BTF is current)")
            return {"FINISHED"}
        # The bake turns the field on when it stores the BTF (a cancelled one leaves the object as it was); in
        # the UI it goes on as its own modal operator, and this one is done.
        result = bpy.ops.translucent.bake_grass_btf(how)
        return {"FINISHED"} if "RUNNING_MODAL" in result else result


classes = (TRANSLUCENT_OT_bake_grass_btf, TRANSLUCENT_OT_add_grass_field)
