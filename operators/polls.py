"""What an operator needs before it can run, as ``poll()``: a button greys out and its tooltip says why
(``poll_message_set``), instead of an error after the click. Cheap: polls run on every redraw."""
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


def mesh(cls, context, what: str) -> bool:
    _, why = active_mesh(context, what)
    return refuse(cls, why) if why else True


def bakeable(cls, context) -> bool:
    """An active mesh whose method bakes something."""
    ob, why = active_mesh(context)
    if why:
        return refuse(cls, why)
    if not registry.needs_bake(ob.translucent.method):
        return refuse(cls, f"'{ob.name}': nothing to bake, {registry.no_bake_reason(ob.translucent.method)}")
    return True


def baked(cls, context) -> bool:
    """An active mesh holding a bake."""
    ob, why = active_mesh(context, "clear its bake")
    if why:
        return refuse(cls, why)
    if store.BAKE_KEY not in bake_files.owner(ob):
        return refuse(cls, f"'{ob.name}' holds no bake")
    return True


def ground(cls, context) -> bool:
    """An active mesh with faces to grow grass on."""
    ob, why = active_mesh(context, "grow grass on")
    if why:
        return refuse(cls, why)
    if len(ob.data.polygons) == 0:
        return refuse(cls, f"'{ob.name}' has no faces to grow grass on")
    return True


def camera(cls, context) -> bool:
    if context.scene is None or context.scene.camera is None:
        return refuse(cls, "the scene has no active camera: the comparison renders the camera's view")
    return True
