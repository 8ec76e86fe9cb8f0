"""translucent.bake, translucent.bake_all, translucent.clear_bake and translucent.purge_bakes.

The bake is a generator of stages (``translucent_addon.techniques.registry.run``). In
the UI the operator is modal: a timer steps the generator, the status bar shows
progress, Esc cancels. In background mode (batch, scripts) it runs blocking and
prints one progress line per step. Nothing is written until the last step, so
a cancelled or failed bake leaves the object as it was. Bake All runs the bakes of
many objects as one such job, each object written when its own bake ends.
"""

import time

import bpy

from ..translucent_addon.blender import bake_files, material_surface
from ..translucent_addon.blender.bake_inputs import bake_status, gather, make_proxies, serves_others
from ..translucent_addon.blender.quality_apply import apply_auto, restore
from ..translucent_addon.blender.session import current as current_session
from ..translucent_addon.gpu import bake_cache
from ..translucent_addon.techniques import registry
from . import polls
from .polls import active_mesh as _active_mesh


class ModalJob:
    """A long job on the active object as a generator of (fraction, text): modal in the UI, with a progress bar
    and what runs now in the status bar (``_draw_status``) and Esc, blocking with progress lines in background
    mode. Subclasses give ``_prepare`` (context -> (object, inputs) or None, having reported why), ``_job_for``
    (inputs -> generator) and ``_finish`` (object, inputs, result), which alone writes to the object; what
    ``_prepare`` had to write first it undoes in ``_undo_prepare``. One job runs at a time (``running``): the
    progress bar is the window's."""

    running: set = set()  # the modal jobs in progress (their operators)
    _timer = None
    _job = None
    _inputs = None
    _title = "Translucent bake"
    _what = "bake"
    _errors = (registry.BakeInputError,)  # raised by a job step: reported in one line, nothing written

    def _job_for(self, inputs):
        return registry.run(inputs)

    def execute(self, context):
        prepared = self._prepare(context)
        if prepared is None:
            return {"CANCELLED"}
        ob, inputs = prepared
        self._t0 = time.perf_counter()
        job = self._job_for(inputs)
        printed = (None, 0.0)
        try:
            while True:
                fraction, text = next(job)
                # A step waiting on a child process reports every 50 ms: a line when the step changes, or 5 s on.
                step, now = text.split(" (")[0], time.perf_counter()
                if step != printed[0] or now - printed[1] >= 5.0:
                    print(f"{self._title} '{ob.name}': {100 * fraction:5.1f} % {text}", flush=True)
                    printed = (step, now)
        except StopIteration as done:
            self._finish(ob, inputs, done.value)
        except self._errors as err:  # found by a step (e.g. tetrahedra): one line, object unchanged
            self._undo_prepare(ob)
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        except BaseException:
            self._undo_prepare(ob)
            raise
        return {"FINISHED"}

    def _undo_prepare(self, ob) -> None:
        """Put back what ``_prepare`` wrote: the job did not finish."""

    def _cancelled(self) -> str:
        """What Esc left, said in the status bar."""
        return f"'{self._object.name}': {self._what} cancelled, nothing changed"

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        prepared = self._prepare(context)
        if prepared is None:
            return {"CANCELLED"}
        self._object, self._inputs = prepared
        self._t0 = time.perf_counter()
        self._job = self._job_for(self._inputs)
        wm = context.window_manager
        wm.progress_begin(0, 100)
        self._timer = wm.event_timer_add(0.05, window=context.window)
        wm.modal_handler_add(self)
        ModalJob.running.add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self._job.close()  # runs the job's cleanup (restores what a step changed) now
            self._undo_prepare(self._object)
            self._end(context, self._cancelled())
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            fraction, text = next(self._job)
        except StopIteration as done:
            try:
                self._finish(self._object, self._inputs, done.value)
            except Exception as err:  # storing the result failed: the modal still ends, and says why
                self._undo_prepare(self._object)
                self._end(context, f"'{self._object.name}': {self._what} could not be stored: {err}", level="ERROR")
                return {"CANCELLED"}
            self._end(context, None)
            return {"FINISHED"}
        except Exception as err:  # a failing stage must not leave the modal running
            self._undo_prepare(self._object)
            self._end(context, f"'{self._object.name}': {self._what} failed: {err}", level="ERROR")
            return {"CANCELLED"}
        context.window_manager.progress_update(int(100 * fraction))
        self._progress = (fraction, text)
        context.workspace.status_text_set(self._draw_status)  # drawn again with the new fraction
        return {"RUNNING_MODAL"}

    _progress = (0.0, "")

    def _draw_status(self, header, context) -> None:
        """The status bar while the job runs: a progress bar with the share done, what runs now, and Esc."""
        fraction, text = self._progress
        row = header.layout.row(align=True)
        row.progress(factor=fraction, type="BAR", text=f"{self._title}: {100 * fraction:.0f} %")
        row.label(text=f"{text} (Esc to cancel)")

    def cancel(self, context):
        """Blender ends the modal without an event (a file opened, Blender closed): the job stops and the next
        one may start. The object is left alone: its file may be on its way out."""
        if self in ModalJob.running:
            self._job.close()
            self._end(context, None)

    def _end(self, context, message, level="WARNING"):
        ModalJob.running.discard(self)
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        if message:
            self.report({level}, message)


class TRANSLUCENT_OT_bake(ModalJob, bpy.types.Operator):
    """Precompute what the active object's translucency method needs and keep it with its mesh"""

    bl_idname = "translucent.bake"
    bl_label = "Bake"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return polls.idle(cls, ModalJob.running) and polls.bakeable(cls, context)

    def _prepare(self, context):
        ob, error = _active_mesh(context)
        if error:
            self.report({"ERROR"}, error)
            return None
        self._previous = {}
        try:
            inputs = _inputs(self, context, ob, self._previous)
        except registry.BakeInputError as err:
            self.report({"ERROR"}, str(err))
            return None
        return ob, inputs

    def _undo_prepare(self, ob) -> None:
        restore(ob, self._previous)  # the Auto resolutions written for the bake

    def _job_for(self, inputs):
        return _proxies_then_bake(inputs)

    def _finish(self, ob, inputs, result):
        seconds = _store(self, ob, inputs, result, self._t0)
        self.report({"INFO"}, f"'{ob.name}': {inputs.method} baked in {seconds:.2f} s")


def _inputs(op, context, ob, previous: dict):
    """A bake's inputs for ``ob`` (its Auto quality resolved first, written into ``previous`` to be put back if the
    bake does not finish); warnings and notes reported on ``op``. Raises ``BakeInputError``, ``previous`` put back."""
    if ob.translucent.quality == "AUTO" and registry.bakes_auto(ob.translucent.method):
        choice = apply_auto(context, ob, previous)
        op.report({"INFO"}, f"'{ob.name}' Auto: {choice.summary()}")
    depsgraph = context.evaluated_depsgraph_get()
    try:
        inputs = gather(ob.evaluated_get(depsgraph), for_bake=True, proxies=False)  # the job makes them
        for warning in registry.validate(inputs):
            op.report({"WARNING"}, warning)
    except registry.BakeInputError:
        restore(ob, previous)
        raise
    if ob.modifiers:
        op.report({"INFO"}, f"'{ob.name}': baked with its modifiers applied; editing them marks the bake stale")
    return inputs


def _store(op, ob, inputs, result, t0: float) -> float:
    """Write a finished bake (on the mesh, or the object when the mesh's serves other duplicates); its seconds."""
    arrays, meta = result
    meta["seconds"] = round(time.perf_counter() - t0, 3)
    digest = inputs.hash()
    own = serves_others(ob, inputs.method, digest)
    why = bake_files.write(ob, inputs.method, digest, arrays, meta, bpy.context.scene, own=own)
    if own:
        op.report({"INFO"}, f"'{ob.name}': differs from the linked duplicates sharing its mesh (scale, "
                            f"material or modifiers): its bake is kept on the object")
    if why:
        op.report({"WARNING"}, why)
    bake_cache.forget(ob.name)
    return meta["seconds"]


def _proxies_then_bake(inputs):
    """The bake's job: the proxies (``make_proxies``: the status line says which, Esc stops between them), then
    its stages (the progress bar counts those)."""
    for _, text in make_proxies(inputs):
        yield 0.0, text
    return (yield from registry.run(inputs))


def _to_bake(objects, depsgraph, everything: bool = False) -> list:
    """The mesh objects among ``objects`` whose method bakes and whose bake is missing or stale (every such one
    with ``everything``); an object whose inputs cannot be read is listed (its bake will say why)."""
    found = []
    for ob in objects:
        if ob.type != "MESH" or not registry.needs_bake(ob.translucent.method):
            continue
        try:
            stale = everything or bake_status(ob.evaluated_get(depsgraph), ob.translucent.method) != "OK"
        except registry.BakeInputError:
            stale = True
        if stale:
            found.append(ob)
    return found


class TRANSLUCENT_OT_bake_all(ModalJob, bpy.types.Operator):
    """Bake every object of the scene whose bake is missing or out of date (or the selected objects), one after
    another in one job with one progress bar; an object that fails is named and the others are still baked"""

    bl_idname = "translucent.bake_all"
    bl_label = "Bake All"
    bl_options = {"REGISTER", "UNDO"}
    _what = "bake of every object"

    selected_only: bpy.props.BoolProperty(
        name="Selected only", default=False,
        description="Bake the selected objects (also those whose bakes are up to date), not the whole scene")

    @classmethod
    def poll(cls, context):
        return polls.idle(cls, ModalJob.running) and (context.scene is not None or polls.refuse(cls, "no scene"))

    def _prepare(self, context):
        depsgraph = context.evaluated_depsgraph_get()
        objects = context.selected_objects if self.selected_only else context.scene.objects
        pending = _to_bake(objects, depsgraph, everything=self.selected_only)
        if not pending:
            what = "of the selected objects" if self.selected_only else "in the scene"
            self.report({"INFO"}, f"nothing to bake {what}: every bake is up to date")
            return None
        self._names = [ob.name for ob in pending]
        self._baked, self._failed = [], []
        return context.scene, pending

    def _cancelled(self) -> str:
        done = f"{len(self._baked)} baked ({', '.join(self._baked)})" if self._baked else "none baked"
        return f"Bake All cancelled: {done}, {len(self._names) - len(self._baked)} left as they were"

    def _job_for(self, pending):
        return self._bake_each(bpy.context, pending)

    def _bake_each(self, context, pending):
        """Generator of (fraction, text) over every object's bake; each object written when its bake ends. An
        object whose bake fails is recorded (``_failed``) and the job goes on."""
        n = len(pending)
        for i, ob in enumerate(pending):
            if not self.selected_only and not _to_bake([ob], context.evaluated_depsgraph_get()):
                self._names.remove(ob.name)  # a linked duplicate baked before it: it shares that bake
                continue
            label = f"'{ob.name}' ({i + 1}/{n})"
            previous = {}
            t0 = time.perf_counter()
            job = None
            try:
                inputs = _inputs(self, context, ob, previous)
                job = _proxies_then_bake(inputs)
                while True:
                    try:
                        fraction, text = next(job)
                    except StopIteration as done:
                        result = done.value
                        break
                    yield (i + fraction) / n, f"{label}: {text}"
                _store(self, ob, inputs, result, t0)
                self._baked.append(ob.name)
                print(f"Translucent Bake All: {label} {inputs.method} baked in {time.perf_counter() - t0:.1f} s",
                      flush=True)
            except GeneratorExit:  # Esc: this object is left as it was, those baked before stay baked
                restore(ob, previous)
                raise
            except Exception as err:  # this object's bake failed: said, left as it was, the others go on
                restore(ob, previous)
                self._failed.append((ob.name, str(err)))
                print(f"Translucent Bake All: {label} failed: {err}", flush=True)
            finally:
                if job is not None:
                    job.close()  # the stage's own cleanup runs now
        return None

    def _finish(self, scene, pending, result):
        seconds = time.perf_counter() - self._t0
        skipped = len(pending) - len(self._names)
        text = f"Bake All: {len(self._baked)} of {len(self._names)} object(s) baked in {seconds:.1f} s"
        if skipped:
            text += f" ({skipped} linked duplicate(s) share a bake made here)"
        self.report({"INFO"}, text)
        if self._failed:
            self.report({"ERROR"}, f"Bake All: {len(self._failed)} bake(s) failed: "
                        + "; ".join(f"'{name}': {why}" for name, why in self._failed))


class TRANSLUCENT_OT_purge_bakes(bpy.types.Operator):
    """Delete the files in this .blend's bake folder that none of its objects uses any more (older bakes, bakes of
    removed objects). Files the saved .blend still uses are kept; Undo cannot bring back a bake purged here"""

    bl_idname = "translucent.purge_bakes"
    bl_label = "Purge Unused Bake Files"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        return polls.idle(cls, ModalJob.running) and polls.bake_folder(cls)

    def execute(self, context):
        removed, freed = bake_files.purge(current_session().bake_files_saved)
        folder = bake_files.folder_for(bpy.data.filepath)
        if removed:
            self.report({"INFO"}, f"{removed} unused bake file(s) deleted, {freed / 2**20:.1f} MB freed ({folder})")
        else:
            self.report({"INFO"}, f"no unused bake files in {folder}")
        return {"FINISHED"}


class TRANSLUCENT_OT_clear_bake(bpy.types.Operator):
    """Remove the stored bake of the active object's method"""

    bl_idname = "translucent.clear_bake"
    bl_label = "Clear Bake"
    bl_options = {"REGISTER", "UNDO"}

    all_methods: bpy.props.BoolProperty(name="All methods", default=False,
                                        description="Remove the bakes of every method, not only the current one")

    @classmethod
    def poll(cls, context):
        return polls.baked(cls, context)

    def execute(self, context):
        ob, error = _active_mesh(context)
        if error:
            self.report({"ERROR"}, error)
            return {"CANCELLED"}
        method = None if self.all_methods else ob.translucent.method
        if bake_files.clear(ob, method):
            bake_cache.forget(ob.name)
            self.report({"INFO"}, f"'{ob.name}': bake cleared")
        else:
            self.report({"INFO"}, f"'{ob.name}': no bake to clear")
        return {"FINISHED"}


class TRANSLUCENT_OT_bake_textures(bpy.types.Operator):
    """Bake the node graphs on the active object's Base Colors (procedural textures, mixes, ramps) into UV images
    through Cycles, so that the real-time methods draw them; kept packed in the .blend"""

    bl_idname = "translucent.bake_textures"
    bl_label = "Bake Textures"
    bl_options = {"REGISTER", "UNDO"}

    size: bpy.props.IntProperty(name="Size", description="Texels per side of each baked image", default=1024,
                                min=64, max=8192)

    @classmethod
    def poll(cls, context):
        def why_not(ob):
            if not material_surface.graphs_to_bake(ob):
                return f"'{ob.name}': no Base Color of its materials is a node graph to bake"
            if not ob.data.uv_layers:
                return f"'{ob.name}' has no UV map to bake through (add one: UV > Unwrap)"
            return None

        return polls._mesh_that(cls, context, "bake its textures", why_not)

    def execute(self, context):
        ob = context.active_object
        t0 = time.perf_counter()
        try:
            done = material_surface.bake_textures(ob, self.size, progress=lambda text: print(text, flush=True))
        except RuntimeError as err:  # Cycles' own refusal (no UV map, an image it cannot write)
            self.report({"ERROR"}, f"'{ob.name}': Cycles could not bake its textures: {err}")
            return {"CANCELLED"}
        if done:
            self.report({"INFO"}, f"'{ob.name}': {len(done)} texture(s) baked in {time.perf_counter() - t0:.1f} s")
        else:
            self.report({"INFO"}, f"'{ob.name}': its baked textures are current")
        return {"FINISHED"}


classes = (TRANSLUCENT_OT_bake, TRANSLUCENT_OT_bake_all, TRANSLUCENT_OT_clear_bake, TRANSLUCENT_OT_purge_bakes,
           TRANSLUCENT_OT_bake_textures)
