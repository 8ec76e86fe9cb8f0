"""BTF acquisition of a grass patch (Shah 4.3.1): the patch rendered under every sampled view and
light direction, with a depth map per view.

Renderer: our own rasteriser on the bake GPU (moderngl, a headless EGL context; Mesa llvmpipe
where there is no GPU). Shah rendered with an offline global-illumination renderer after Suykens
et al.; ours draws direct light only (leaf reflection, leaf transmission, a cuticle sheen and
shadows between blades), which keeps 1,701 images to seconds instead of hours. Every texel of an
image sees the same view and light direction (orthographic camera, directional light).

Parametrisation (what the renderer at run time relies on): pixel (i, j) of an image is the point
q = ((i + 0.5) / R, (j + 0.5) / R, h) on the top plane of the grass layer (h = the tallest blade);
its ray leaves q along -omega_v (omega_v points to the viewer) and the depth map holds the distance
d along it to the first blade, in tile units, or -1 (the sentinel) where the ray reaches the ground
without touching a blade. The patch repeats with period 1, so the images are tileable exactly.
Radiance is per unit irradiance on a plane facing the light (the light's E_perp = 1).
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from ...core.geometry import hemisphere
from ...gpu.gl_context import preserve_current_context, standalone_backend
from .patch import GrassPatch

SENTINEL = -1.0
SHEEN_EXPONENT = 30.0  # the cuticle's Blinn-Phong exponent (the shader's SHEEN_EXPONENT)


def sheen_normalisation(e: float) -> float:
    """(e + 8) / (8 pi): the Blinn-Phong BRDF specular (e + 8) / (8 pi) (n.h)^e reflects about ``specular``
    of the light at normal incidence and less elsewhere (energy-normalised Blinn-Phong, Akenine-Moller et
    al., Real-Time Rendering, 3rd ed., Eq. 7.49). The lobe's NDF constant (e + 2) / (2 pi), used as a BRDF
    before, reflected 3.4 times that at e = 30: a white sheen of 0.14 on leaves of albedo 0.02-0.1, the
    haze the field showed against Cycles."""
    return (e + 8.0) / (8.0 * np.pi)


def sheen_brdf(n_dot_h, specular: float, e: float = SHEEN_EXPONENT):
    """The acquisition's cuticle sheen as a BRDF (NumPy twin of the view shader's lobe)."""
    return specular * sheen_normalisation(e) * np.maximum(np.asarray(n_dot_h, float), 0.0) ** e

_VERTEX = """
#version 330
uniform mat4 projection;   // sheared orthographic map of the patch onto the top plane
uniform vec2 tile_offset[81];
in vec3 in_pos; in vec3 in_nor; in vec3 in_rho_r; in vec3 in_rho_t;
out vec3 v_pos; out vec3 v_nor; out vec3 v_rho_r; out vec3 v_rho_t;
void main() {
  vec3 p = in_pos + vec3(tile_offset[gl_InstanceID], 0.0);
  v_pos = p; v_nor = in_nor; v_rho_r = in_rho_r; v_rho_t = in_rho_t;
  gl_Position = projection * vec4(p, 1.0);
}
"""

_SHADOW_FRAGMENT = """
#version 330
uniform vec3 omega;  // towards the light
uniform float h;
in vec3 v_pos;
out float out_depth;
void main() { out_depth = (h - v_pos.z) / omega.z; }
"""

_VIEW_FRAGMENT = """
#version 330
#define PI 3.14159265358979
#define SHEEN_EXPONENT 30.0
uniform vec3 omega_v;   // towards the viewer
uniform vec3 omega_l;   // towards the light
uniform float h;
uniform float specular;
uniform float sheen_norm;  // sheen_normalisation(SHEEN_EXPONENT)
uniform float shadow_bias;
uniform sampler2D shadow_map;  // distances along the light's rays from the top plane, period 1
in vec3 v_pos; in vec3 v_nor; in vec3 v_rho_r; in vec3 v_rho_t;
layout(location = 0) out vec4 out_color;
layout(location = 1) out float out_depth;

float lit(vec3 p) {
  // The light's ray through p leaves the top plane at q_l, d_l before p.
  float d_l = (h - p.z) / omega_l.z;
  vec2 q = p.xy + d_l * omega_l.xy;
  vec2 size = vec2(textureSize(shadow_map, 0));
  vec2 t = q * size - 0.5;
  vec2 f = fract(t);
  ivec2 i0 = ivec2(floor(t));
  float v[4];
  for (int k = 0; k < 4; k++) {  // 2x2 percentage-closer filter, wrapped (the patch is periodic)
    ivec2 c = (i0 + ivec2(k & 1, k >> 1)) % ivec2(size);
    c += ivec2(size) * ivec2(lessThan(c, ivec2(0)));
    v[k] = float(texelFetch(shadow_map, c, 0).r >= d_l - shadow_bias);
  }
  return mix(mix(v[0], v[1], f.x), mix(v[2], v[3], f.x), f.y);
}

void main() {
  vec3 n = normalize(v_nor);
  if (dot(n, omega_v) < 0.0) n = -n;  // two-sided leaf: the side the viewer sees
  float c = dot(n, omega_l);
  vec3 L;
  if (c > 0.0) {
    vec3 hv = normalize(omega_l + omega_v);
    L = v_rho_r / PI * c + vec3(specular * sheen_norm * pow(max(dot(n, hv), 0.0), SHEEN_EXPONENT) * c);
  } else {
    L = v_rho_t / PI * (-c);  // transmitted through the blade
  }
  out_color = vec4(L * lit(v_pos), 1.0);
  out_depth = (h - v_pos.z) / omega_v.z;
}
"""


def sheared_projection(omega: np.ndarray, h: float, d_max: float) -> np.ndarray:
    """Column-vector matrix taking a patch point p to NDC: x, y of the point where the ray through p
    along omega meets the top plane z = h (the unit square to [-1, 1]^2), z from the distance
    d = (h - p_z) / omega_z along that ray (0..d_max to -1..1)."""
    ox, oy, oz = (float(c) for c in omega)
    M = np.zeros((4, 4))
    M[0] = [2.0, 0.0, -2.0 * ox / oz, 2.0 * h * ox / oz - 1.0]
    M[1] = [0.0, 2.0, -2.0 * oy / oz, 2.0 * h * oy / oz - 1.0]
    M[2] = [0.0, 0.0, -2.0 / (oz * d_max), 2.0 * h / (oz * d_max) - 1.0]
    M[3] = [0.0, 0.0, 0.0, 1.0]
    return M


@dataclasses.dataclass
class BTFImages:
    """Acquired BTF: radiance per unit irradiance and depth maps."""

    images: np.ndarray  # (n_v, n_l, R, R, 3) float32, rows = j (y), columns = i (x)
    depth: np.ndarray  # (n_v, R, R) float32, tile units along the view ray, SENTINEL where no blade
    views: np.ndarray  # (n_v, 3)
    lights: np.ndarray  # (n_l, 3)
    height: float
    seconds: float = 0.0


class PatchRenderer:
    """Renders a patch at any view and light direction (the acquisition and its checks share it)."""

    def __init__(self, patch: GrassPatch, resolution: int = 128, supersample: int = 2, shadow_resolution: int = 512):
        with preserve_current_context():
            self._create(patch, resolution, supersample, shadow_resolution)

    def _create(self, patch, resolution, supersample, shadow_resolution):
        import moderngl

        self.patch = patch
        self.h = float(patch.params.height)
        self.R = int(resolution)
        self.ss = int(supersample)
        self.ctx = moderngl.create_standalone_context(backend=standalone_backend())
        ctx = self.ctx
        vbo = np.concatenate([patch.positions, patch.normals, patch.rho_r, patch.rho_t], axis=1).astype("f4")
        self._vbo = ctx.buffer(vbo.tobytes())
        self._ibo = ctx.buffer(patch.triangles.astype("i4").tobytes())
        self._view_prog = ctx.program(vertex_shader=_VERTEX, fragment_shader=_VIEW_FRAGMENT)
        self._shadow_prog = ctx.program(vertex_shader=_VERTEX, fragment_shader=_SHADOW_FRAGMENT)
        fmt = (self._vbo, "3f 3f 3f 3f", "in_pos", "in_nor", "in_rho_r", "in_rho_t")
        self._view_vao = ctx.vertex_array(self._view_prog, [fmt], self._ibo)
        self._shadow_vao = ctx.vertex_array(self._shadow_prog, [(self._vbo, "3f 36x", "in_pos")], self._ibo)
        size = self.R * self.ss
        self._color = ctx.texture((size, size), 4, dtype="f4")
        self._depth_out = ctx.texture((size, size), 1, dtype="f4")
        self._zbuf = ctx.depth_texture((size, size))
        self._fbo = ctx.framebuffer([self._color, self._depth_out], self._zbuf)
        self.shadow_resolution = int(shadow_resolution)
        S = self.shadow_resolution
        self._shadow_tex = ctx.texture((S, S), 1, dtype="f4")
        self._shadow_z = ctx.depth_texture((S, S))
        self._shadow_fbo = ctx.framebuffer([self._shadow_tex], self._shadow_z)
        self._shadow_for = None

    def release(self) -> None:
        with preserve_current_context():
            self.ctx.release()

    def _tiles(self, omega: np.ndarray) -> tuple[np.ndarray, int]:
        """Tile offsets whose blades can project into the unit square along omega."""
        reach = self.h * np.hypot(omega[0], omega[1]) / omega[2] + 0.6 * self.h  # the ray, and a blade's lean
        k = int(np.ceil(reach)) + 1
        offs = np.array([(i, j) for i in range(-k, k + 1) for j in range(-k, k + 1)], np.float32)
        if len(offs) > 81:
            raise ValueError("grass too tall for its tile: blades reach more than 4 tiles along a view")
        return offs, len(offs)

    def _draw(self, vao, prog, omega, fbo, d_max) -> None:
        offs, count = self._tiles(omega)
        prog["projection"].write(sheared_projection(omega, self.h, d_max).T.astype("f4").tobytes())
        buf = np.zeros((81, 2), np.float32)
        buf[:count] = offs
        prog["tile_offset"].write(buf.tobytes())
        fbo.use()
        vao.render(instances=count)

    def _d_max(self, omega) -> float:
        return self.h / max(float(omega[2]), 0.05) * 1.01 + 1e-3

    def set_light(self, omega_l: np.ndarray) -> None:
        """Shadow map of the light direction: distances from the top plane along its rays (one period)."""
        import moderngl

        omega_l = np.asarray(omega_l, np.float64) / np.linalg.norm(omega_l)
        if self._shadow_for is not None and np.allclose(self._shadow_for, omega_l):
            return
        ctx = self.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        self._shadow_fbo.use()
        self._shadow_fbo.clear(1e30, 0.0, 0.0, 0.0, depth=1.0)
        ctx.viewport = (0, 0, self.shadow_resolution, self.shadow_resolution)
        self._shadow_prog["omega"].value = tuple(omega_l)
        self._shadow_prog["h"].value = self.h
        self._draw(self._shadow_vao, self._shadow_prog, omega_l, self._shadow_fbo, self._d_max(omega_l))
        self._shadow_for = omega_l

    def render(self, omega_v: np.ndarray, omega_l: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(radiance (R, R, 3) float32, depth (R, R) float32 with SENTINEL) of one view and light.
        Supersampled ss x ss: a pixel is a blade pixel when at least half its samples hit one; its
        radiance and depth are the means over the samples that hit."""
        with preserve_current_context(), self.ctx:
            return self._render(omega_v, omega_l)

    def _render(self, omega_v, omega_l):
        import moderngl

        omega_v = np.asarray(omega_v, np.float64) / np.linalg.norm(omega_v)
        omega_l = np.asarray(omega_l, np.float64) / np.linalg.norm(omega_l)
        self.set_light(omega_l)
        ctx = self.ctx
        size = self.R * self.ss
        self._fbo.use()
        self._fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.viewport = (0, 0, size, size)
        ctx.enable(moderngl.DEPTH_TEST)
        prog = self._view_prog
        prog["omega_v"].value = tuple(omega_v)
        prog["omega_l"].value = tuple(omega_l)
        prog["h"].value = self.h
        prog["specular"].value = float(self.patch.params.specular)
        prog["sheen_norm"].value = sheen_normalisation(SHEEN_EXPONENT)
        prog["shadow_bias"].value = 2.0 * self.h / self.shadow_resolution / max(omega_l[2], 0.2)
        self._shadow_tex.use(0)
        prog["shadow_map"].value = 0
        self._draw(self._view_vao, prog, omega_v, self._fbo, self._d_max(omega_v))
        color = np.frombuffer(self._color.read(), np.float32).reshape(size, size, 4)
        depth = np.frombuffer(self._depth_out.read(), np.float32).reshape(size, size)
        return self._downsample(color, depth)

    def _downsample(self, color, depth):
        s, R = self.ss, self.R
        hit = color[..., 3].reshape(R, s, R, s)
        n_hit = hit.sum(axis=(1, 3))
        rgb = (color[..., :3] * color[..., 3:4]).reshape(R, s, R, s, 3).sum(axis=(1, 3))
        d = (depth * color[..., 3]).reshape(R, s, R, s).sum(axis=(1, 3))
        blade = n_hit >= 0.5 * s * s
        safe = np.maximum(n_hit, 1.0)
        radiance = np.where(blade[..., None], rgb / safe[..., None], 0.0).astype(np.float32)
        dist = np.where(blade, d / safe, SENTINEL).astype(np.float32)
        return radiance, dist


def acquire(patch: GrassPatch, resolution: int = 128, views: np.ndarray | None = None,
            lights: np.ndarray | None = None, supersample: int = 2):
    """Generator: yields (fraction, text) per light; returns BTFImages. Light-major inside each view
    would re-render shadow maps, so lights are the outer loop and views the inner one."""
    views = hemisphere.view_directions() if views is None else np.asarray(views, np.float64)
    lights = hemisphere.light_directions() if lights is None else np.asarray(lights, np.float64)
    t0 = time.perf_counter()
    R = int(resolution)
    images = np.zeros((len(views), len(lights), R, R, 3), np.float32)
    depth = np.zeros((len(views), R, R), np.float32)
    renderer = PatchRenderer(patch, R, supersample)
    try:
        for li, omega_l in enumerate(lights):
            for vi, omega_v in enumerate(views):
                images[vi, li], d = renderer.render(omega_v, omega_l)
                if li == 0:
                    depth[vi] = d
            yield (li + 1) / len(lights), f"grass BTF: light {li + 1} of {len(lights)} ({len(views)} views)"
    finally:
        renderer.release()
    return BTFImages(images, depth, views, lights, float(patch.params.height), time.perf_counter() - t0)


def run(generator):
    """Drive a bake generator to its return value (scripts and tests)."""
    while True:
        try:
            next(generator)
        except StopIteration as stop:
            return stop.value
