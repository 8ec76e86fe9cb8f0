"""translucent.compare_cycles: our engine against Cycles and EEVEE, with report and chart."""
import bpy

from ..translucent_addon.blender import compare_runner as runner
from ..translucent_addon.blender import preferences
from . import polls
from .bake import ModalJob


class TRANSLUCENT_OT_compare_cycles(ModalJob, bpy.types.Operator):
    """Render the camera view with Translucent, Cycles (random walk, brute force) and EEVEE; write
    report.json, images, error images and the speed-vs-accuracy chart. In the UI: a progress bar, one
    step per render, Esc cancels between renders"""

    bl_idname = "translucent.compare_cycles"
    bl_label = "Compare with Cycles"
    _title = "Translucent compare"
    _what = "comparison"
    _errors = (runner.CompareError,)

    @classmethod
    def poll(cls, context):
        return polls.camera(cls, context)

    output_dir: bpy.props.StringProperty(name="Output folder", subtype="DIR_PATH", default="//translucent_compare",
                                         description="Where the report, images and chart are written")
    quick: bpy.props.BoolProperty(name="Quick", description="Few samples: a first look in minutes", default=False)
    cache_dir: bpy.props.StringProperty(name="Cache folder", subtype="DIR_PATH", default="",
                                        description="Where reference renders are cached (default: the preferences' "
                                                    "cache folder, else output/cache)")

    def _prepare(self, context):
        settings = runner.CompareSettings.quick() if self.quick else runner.CompareSettings()
        prefs = preferences.get(context)
        cache = self.cache_dir or (prefs.cache_folder if prefs is not None else "")
        settings.cache_dir = bpy.path.abspath(cache) if cache else ""
        return context.scene, (context.scene, self.output_dir, settings)

    def _job_for(self, inputs):
        return runner.run_steps(*inputs)

    def _finish(self, scene, inputs, result):
        entries, _ = result
        ours = [e for e in entries if e.engine == "TRANSLUCENT_RT"]
        best = min(ours, key=lambda e: e.rel_rmse) if ours else None
        if best is not None:
            self.report({"INFO"}, f"Translucent {best.settings['label']}: relative RMSE {best.rel_rmse:.3f}, "
                                  f"{best.seconds:.2f} s; report in {self.output_dir}")


classes = (TRANSLUCENT_OT_compare_cycles,)
