"""What an operator needs before it can run, as ``poll()``: a button greys out and its tooltip says why
(``poll_message_set``), instead of an error after the click. Cheap: polls run on every redraw."""
import bpy

from ..translucent_addon.blender import bake_files
from ..translucent_addon.core import bake_store as store
from ..translucent_addon.techniques import registry


def active_mesh(context, what: str = "bake"):
    """(the active mesh object, None) or (None, why not); ``what`` the operator does with it."""
    ob = context.active_object
    if ob is None:
        return None, f"no active object: select a mesh object to {what}"
    if ob.type != "MESH":
        return None, f"'{ob.name}' is a {ob.type.lower()}, not a mesh"
    return ob, None


def refuse(cls, why: str) -> bool:
    """Say why in the tooltip (in the words the operator's own error would use); False."""
    cls.poll_message_set(why)
    return False


def _mesh_that(cls, context, what: str, why_not=lambda ob: None) -> bool:
    """An active mesh (else why not, for ``what``) of which ``why_not(ob)`` finds nothing to say."""
    ob, why = active_mesh(context, what)
    why = why or why_not(ob)
    return refuse(cls, why) if why else True


def mesh(cls, context, what: str) -> bool:
    return _mesh_that(cls, context, what)


def idle(cls, running) -> bool:
    """No long job in progress (one at a time: the progress bar and the status line are the window's)."""
    return not running or refuse(cls, "a bake or comparison is in progress: wait for it, or press Esc to cancel it")


def bakeable(cls, context) -> bool:
    """An active mesh whose method bakes something."""
    return _mesh_that(cls, context, "bake", lambda ob: None if registry.needs_bake(ob.translucent.method) else
                      f"'{ob.name}': nothing to bake, {registry.no_bake_reason(ob.translucent.method)}")


def baked(cls, context) -> bool:
    """An active mesh holding a bake."""
    return _mesh_that(cls, context, "clear its bake", lambda ob: None if store.BAKE_KEY in bake_files.owner(ob)
                      else f"'{ob.name}' holds no bake")


def bake_folder(cls) -> bool:
    """This file has a bake folder (one stat: polls run on every redraw)."""
    folder = bake_files.folder_for(bpy.data.filepath)
    return folder.is_dir() or refuse(cls, f"no bake folder ({folder.name}) yet: nothing to purge")


def ground(cls, context) -> bool:
    """An active mesh with faces to grow grass on."""
    return _mesh_that(cls, context, "grow grass on", lambda ob: None if len(ob.data.polygons)
                      else f"'{ob.name}' has no faces to grow grass on")


def camera(cls, context) -> bool:
    if context.scene is None or context.scene.camera is None:
        return refuse(cls, "the scene has no active camera: the comparison renders the camera's view")
    return True
