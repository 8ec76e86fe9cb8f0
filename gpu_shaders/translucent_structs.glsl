/* Uniform blocks shared by every pass (std140). Packed on the CPU by
 * translucent_addon/render/blocks.py: keep the two in step. */
struct FrameData {
  mat4 view_proj;
  vec4 world_color;     /* rgb: uniform world radiance */
  vec4 camera_position; /* xyz */
};

struct ObjectData {
  mat4 model;
  mat4 normal_matrix; /* inverse transpose of model's 3x3, padded */
};

struct LightData {
  mat4 face_view_proj[6]; /* shadow cube faces +X -X +Y -Y +Z -Z; face 0 only for directional */
  vec4 position_kind;     /* xyz: position (point) or shadow origin (directional); w: 0 dir, 1 point */
  vec4 direction;         /* xyz: unit emission axis */
  vec4 radiance;          /* rgb: irradiance (directional) or on-axis intensity W/sr (point) */
  vec4 cone;              /* x: cos half angle (< -1: none), y: blend width, z: cosine lobe flag */
  vec4 shadow;            /* x: texels per face, y: scene radius, z: normal offset in texels, w: enabled */
};
