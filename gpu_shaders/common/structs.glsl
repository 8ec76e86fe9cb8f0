/* Uniform blocks shared by every pass (std140). Packed on the CPU by
 * translucent_addon/gpu/blocks.py and techniques/image_space/model.py (materials_block): keep them in step. */
struct FrameData {
  mat4 view_proj;
  mat4 view;
  mat4 proj;
  vec4 world_color;     /* rgb: uniform world radiance */
  vec4 camera_position; /* xyz; w: 1 for an orthographic camera */
  vec4 camera_forward;  /* xyz: view direction (orthographic cameras) */
  vec4 world_sh[9];     /* the world's radiance in SH bands 0-2, L_lm rgb (physics/sh_irradiance.py) */
};

struct ObjectData {
  mat4 model;
  mat4 normal_matrix; /* inverse transpose of model's 3x3, padded */
  vec4 shading;       /* x: subsurface tag (common.glsl material_slot; 0: Lambert); y: 1 when mirrored (det < 0) */
};

struct LightData {
  mat4 face_view_proj[6]; /* cube faces +X -X +Y -Y +Z -Z; face 0 only for directional */
  vec4 position_kind;     /* xyz: position (point) or map origin (directional); w: 0 dir, 1 point */
  vec4 direction;         /* xyz: unit emission axis */
  vec4 radiance;          /* rgb: irradiance (directional) or on-axis intensity W/sr (point) */
  vec4 cone;              /* x: cos half angle (< -1: none), y: blend width, z: cosine lobe flag,
                           * w: tan of the half angle of a spot's single fitted shadow face (0: cube) */
  vec4 shadow;            /* x: texels per face, y: scene radius, z: normal offset in texels,
                           * w: shadows on; for light-view samples x: texels, y: texel measure,
                           * z: tangent of a point emitter's face half angle */
};

struct MaterialsData {
  /* per subsurface slot k: [2k] (mm per unit, r_max mm, rho mm, eta),
   *   [2k + 1] (A_0, A_1, A_2 of the world's kernel F_t (n . w) (Funk-Hecke), the world splats' rho mm) */
  vec4 params[64];
  /* per slot k, light through thin parts (physics/slab_through.py): [2k] (sigma_tr rgb per mm, A(eta)),
   *   [2k + 1] (z_r rgb mm, 0) */
  vec4 slab[64];
  /* per slot k, the angular law a(mu) (physics/angular_law.py) at mu = (j + 0.5) / 16: [16 k + j] rgb */
  vec4 angular[512];
  /* per slot k, how light that crossed a thin part leaves (physics/angular_law.through_constants):
   *   [3k] (gamma rgb, 1: on; 0: the Lambertian law), [3k + 1] (k = 1 / nu_0 rgb, 0), [3k + 2] (1 / <M> rgb, 0) */
  vec4 through_exit[96];
  /* per slot k, light entering at an angle (physics/oblique_entry.py): (ell rgb mm, 0), 0 for no shift */
  vec4 entry[32];
  /* per slot k, the near field's lean (physics/exit_lean.py near_constant): (K rgb mm, 0), 0 for no lean */
  vec4 lean[32];
};

struct TemporalData {
  /* IMAGE_SPACE temporal accumulation: per subsurface slot, the inverse of this frame's model
   * matrix and the previous frame's model matrix; the previous camera. */
  mat4 inverse_model[32];
  mat4 previous_model[32];
  mat4 previous_view_proj;
  vec4 tolerance; /* x: world distance under which a reprojected point is the same surface */
};

struct GeocubeData {
  /* GEOCUBE (techniques/geocube/model.py): one object's bake frame (mm) and material. */
  mat4 bake_from_world;
  mat4 world_from_bake;
  vec4 sigma_a;        /* rgb: mm^-1; w: eta */
  vec4 sigma_s;        /* rgb: sigma_s' / (1 - g), mm^-1; w: the minimum step delta (mm) */
  vec4 params;         /* x: cube face texels, y: cubes, z: max steps, w: environment levels */
  vec4 table;          /* x: log(1 + tau_max), y: transfer table entries, z: output mode (0: colour) */
  vec4 env_mean;       /* rgb: C_A, the environment's average */
  vec4 env_levels[16]; /* per key filtered level: x: sigma (rad), y: first atlas row, z: face texels */
};

struct CausticData {
  mat4 grid_view_proj; /* world -> clip of the caster's vertex grid (Shah 5.3.2) */
  vec4 grid;           /* x: grid texels G, y: half extent (tan, point; world, directional),
                        * z: 0 reflective, 1 or 2 refracting surfaces, w: eta */
  vec4 absorption;     /* rgb: K_a per scene unit (Shah Eq. 5.7), w: dispersion (eta spread per channel) */
  vec4 tint;           /* rgb: mirror reflectance of a reflective caster */
  vec4 estimate;       /* x: iterations, y: 0 plain, 1 guard, 2 guard + secant, z: atlas texels per face, w: channels (1, 3) */
  vec4 splat;          /* x: smallest Gaussian sigma (texels), y: adaptive (1), z: largest sigma */
};

struct GrassData {
  vec4 scale;  /* x: tile side (scene units), y: layer height (tile units), z: BTF texels R, w: table res */
  vec4 counts; /* x: views, y: lights, z: -, w: texels per pixel where fewer eigen-textures begin (0: off) */
  vec4 groups; /* x, y, z: groups of four eigen-textures of Y, Cb, Cr; w: fewest Y groups far away */
};

struct ReliefData {
  vec4 params; /* x: depth (scene units, height 1 to 0), y: linear steps, z: most refinements, w: output 1 */
  vec4 mode;   /* x: 0 interval mapping, 1 relief mapping; y: self-shadowing on */
};
