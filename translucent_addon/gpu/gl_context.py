"""Keep the host's OpenGL context current around bake-GPU work.

A moderngl standalone context is made current on the calling thread when it is created and when it
is entered, and leaving it makes no context current. Inside Blender that thread also draws with
Blender's own context, which Blender does not re-bind before every call (freeing a shader without it
aborts). ``preserve_current_context`` saves whatever context is current (EGL, GLX, WGL or CGL) and
makes it current again afterwards.
"""
from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import functools
import sys

# moderngl's standalone backend per platform (glcontext's module of that name): a headless EGL context on
# Linux (X11/GLX needs a display, which background Blender has not), WGL on Windows, CGL on macOS (OpenGL
# 4.1 core there: the bake shaders ask for GLSL 3.30).
STANDALONE_BACKENDS = {"linux": "egl", "win32": "wgl", "darwin": "darwin"}


def standalone_backend(platform: str = sys.platform) -> str | None:
    """The ``backend`` argument of ``moderngl.create_standalone_context`` here: "egl" on Linux, else None
    (moderngl's own choice: the platform's one backend)."""
    return "egl" if platform.startswith("linux") else None


class _EGL:
    def __init__(self):
        lib = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
        for name in ("eglGetCurrentContext", "eglGetCurrentDisplay", "eglGetCurrentSurface"):
            getattr(lib, name).restype = ctypes.c_void_p
        lib.eglGetCurrentSurface.argtypes = [ctypes.c_int]
        lib.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
        self.lib = lib

    def save(self):
        ctx = self.lib.eglGetCurrentContext()
        if not ctx:
            return None
        return (self.lib.eglGetCurrentDisplay(), self.lib.eglGetCurrentSurface(0x3059),  # EGL_DRAW
                self.lib.eglGetCurrentSurface(0x305A), ctx)  # EGL_READ

    def restore(self, saved):
        self.lib.eglMakeCurrent(*saved)


class _GLX:
    def __init__(self):
        lib = ctypes.CDLL(ctypes.util.find_library("GL") or "libGL.so.1")
        for name in ("glXGetCurrentContext", "glXGetCurrentDisplay"):
            getattr(lib, name).restype = ctypes.c_void_p
        for name in ("glXGetCurrentDrawable", "glXGetCurrentReadDrawable"):
            getattr(lib, name).restype = ctypes.c_ulong
        lib.glXMakeContextCurrent.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_void_p]
        self.lib = lib

    def save(self):
        ctx = self.lib.glXGetCurrentContext()
        if not ctx:
            return None
        return (self.lib.glXGetCurrentDisplay(), self.lib.glXGetCurrentDrawable(),
                self.lib.glXGetCurrentReadDrawable(), ctx)

    def restore(self, saved):
        self.lib.glXMakeContextCurrent(*saved)


class _WGL:
    def __init__(self):
        lib = ctypes.WinDLL("opengl32")  # type: ignore[attr-defined]
        lib.wglGetCurrentContext.restype = ctypes.c_void_p
        lib.wglGetCurrentDC.restype = ctypes.c_void_p
        lib.wglMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
        self.lib = lib

    def save(self):
        ctx = self.lib.wglGetCurrentContext()
        return (self.lib.wglGetCurrentDC(), ctx) if ctx else None

    def restore(self, saved):
        self.lib.wglMakeCurrent(*saved)


class _CGL:
    def __init__(self):
        lib = ctypes.CDLL("/System/Library/Frameworks/OpenGL.framework/OpenGL")
        lib.CGLGetCurrentContext.restype = ctypes.c_void_p
        lib.CGLSetCurrentContext.argtypes = [ctypes.c_void_p]
        self.lib = lib

    def save(self):
        ctx = self.lib.CGLGetCurrentContext()
        return (ctx,) if ctx else None

    def restore(self, saved):
        self.lib.CGLSetCurrentContext(*saved)


@functools.cache
def _available() -> tuple:
    """The platform's context APIs that load here (found once: what the system offers does not change)."""
    kinds = {"win32": (_WGL,), "darwin": (_CGL,)}.get(sys.platform, (_EGL, _GLX))
    apis = []
    for kind in kinds:
        try:
            apis.append(kind())
        except (OSError, AttributeError):
            pass
    return tuple(apis)


@contextlib.contextmanager
def preserve_current_context():
    """Run the body (bake-GPU work) and then make the previously current context current again."""
    saved = [(api, api.save()) for api in _available()]
    try:
        yield
    finally:
        for api, state in saved:
            if state is not None:
                api.restore(state)
