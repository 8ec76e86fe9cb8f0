"""translucent.compare_cycles: our engine against Cycles and EEVEE, with report and chart."""
import tempfile
from pathlib import Path

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
        return polls.idle(cls, ModalJob.running) and polls.camera(cls, context)

    output_dir: bpy.props.StringProperty(name="Output folder", subtype="DIR_PATH", default="//translucent_compare",
                                         description="Where the report, images and chart are written (an unsaved "
                                                     "file: the preferences' cache folder)")
    extent: bpy.props.EnumProperty(
        name="Comparison", default="QUICK", description="How many renders, at how many samples",
        items=(("QUICK", "Quick", "Few samples: a first look in minutes", 0),
               ("FULL", "Full", "Every setting and sample count, a 1024-sample reference: can take hours", 1)))
    quick: bpy.props.BoolProperty(name="Quick", default=False, options={"SKIP_SAVE"},
                                  description="Scripts: the quick comparison whatever Comparison says")
    cache_dir: bpy.props.StringProperty(name="Cache folder", subtype="DIR_PATH", default="",
                                        description="Where reference renders are cached (default: the preferences' "
                                                    "cache folder, else output/cache)")

    def _settings(self):
        quick = self.quick or self.extent == "QUICK"
        return runner.CompareSettings.quick_settings() if quick else runner.CompareSettings()

    def invoke(self, context, event):
        """The dialog: Quick or Full, each with the time it takes here (Cycles measured on this scene)."""
        if bpy.app.background:
            return self.execute(context)
        self._expected = {}
        try:
            for kind, settings in (("QUICK", runner.CompareSettings.quick_settings()),
                                   ("FULL", runner.CompareSettings())):
                self._expected[kind] = (runner.expected_seconds(context.scene, settings), settings)
        except Exception:  # noqa: BLE001 - Cycles could not render the scene now: the dialog goes without times
            self._expected = {}
        self._from_dialog = True
        return context.window_manager.invoke_props_dialog(self, width=420)

    def execute(self, context):
        if getattr(self, "_from_dialog", False):  # confirmed in the dialog: modal, with progress and Esc
            self._from_dialog = False
            return ModalJob.invoke(self, context, None)
        return ModalJob.execute(self, context)

    def draw(self, context):
        layout = self.layout
        layout.row().prop(self, "extent", expand=True)
        methods = runner.object_methods(runner.translucent_objects(context.scene))
        for kind, (seconds, settings) in getattr(self, "_expected", {}).items():
            renders = settings.renders(methods)
            layout.label(text=f"{kind.capitalize()}: about {_duration(seconds)} here ({renders} renders, "
                              f"Cycles {settings.cycles_pixel_samples():,} samples per pixel in all)",
                         icon="TIME" if kind == self.extent else "BLANK1")
        layout.prop(self, "output_dir")
        if self.output_dir.startswith("//") and not bpy.data.filepath:
            layout.label(text=f"The file is unsaved: the report goes to {_output_folder(context, self.output_dir)}",
                         icon="INFO")

    def _prepare(self, context):
        settings = self._settings()
        prefs = preferences.get(context)
        cache = self.cache_dir or (prefs.cache_folder if prefs is not None else "")
        settings.cache_dir = bpy.path.abspath(cache) if cache else ""
        self._output = _output_folder(context, self.output_dir)
        return context.scene, (context.scene, self._output, settings)

    def _job_for(self, inputs):
        return runner.run_steps(*inputs)

    def _finish(self, scene, inputs, result):
        entries, _ = result
        ours = [e for e in entries if e.engine == "TRANSLUCENT_RT"]
        best = min(ours, key=lambda e: e.rel_rmse) if ours else None
        noise = float(result[1].get("reference_noise", {}).get("rel_rmse", float("nan")))
        unresolved = [e for e in entries if e.below_reference_noise]
        if unresolved:
            self.report({"WARNING"}, f"{len(unresolved)} result(s) are within the reference's own noise (relative "
                                     f"RMSE {noise:.3f}): the reference cannot rank them; use Full or more "
                                     f"reference samples")
        if best is not None:
            self.report({"INFO"}, f"Translucent {best.settings['label']}: relative RMSE {best.rel_rmse:.3f} "
                                  f"(the reference's noise {noise:.3f}), {best.seconds:.2f} s; report in "
                                  f"{self._output}")
        _show(Path(self._output) / "chart.png")


def _output_folder(context, output_dir: str) -> str:
    """The report's folder: beside the .blend ("//..."); for an unsaved file, in the preferences' cache folder,
    else the system's temporary folder, never the working directory."""
    if not output_dir.startswith("//") or bpy.data.filepath:
        return bpy.path.abspath(output_dir)
    prefs = preferences.get(context)
    base = bpy.path.abspath(prefs.cache_folder) if prefs is not None and prefs.cache_folder else ""
    return str(Path(base or tempfile.gettempdir()) / "translucent" / output_dir[2:])


def _duration(seconds: float) -> str:
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def _show(chart: Path) -> None:
    """Open the chart in Blender: loaded as an image, shown in an Image Editor of the window if there is one."""
    if not chart.is_file():
        return
    image = bpy.data.images.load(str(chart), check_existing=True)
    image.reload()
    if bpy.app.background or bpy.context.window is None:
        return
    for area in bpy.context.window.screen.areas:
        if area.type == "IMAGE_EDITOR":
            area.spaces.active.image = image
            return


classes = (TRANSLUCENT_OT_compare_cycles,)
