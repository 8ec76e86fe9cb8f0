/* Base pass. Lambert objects: rho / pi * E_sh(n) of the world (mode 0; rho L_w for a uniform one), rho / pi * E * V per emitter (mode 1).
 * Subsurface objects (shading.x > 0): the world term F_t(w_o) / pi E_sh(n) near_w(M_d) M_i (its reflection
 * F_r L_w is the surface layer's, pipeline/surface_layer.glsl),
 * E_sh the world's transmitted irradiance in spherical harmonics (Shah 6.4.2) and near_w the world
 * splats' near field (or the whole profile R_d when the world is not peeled: a locally flat
 * surface), and per emitter the near field of the
 * profile F_t(w_o) / pi * E F_t(w_i) V * near(M_d) * M_i (the far field is splatted by
 * IMAGE_SPACE). Subsurface light leaves weighed by the angular law's a(cos_o), and an emitter's enters
 * weighed by a(cos_i) (common/angular_law.glsl; the world's light is diffuse, over which a averages 1); an
 * emitter's near field leans away from where its light entered (physics/exit_lean.py).
 * The painted mask m blends subsurface (m = 1) and Lambert (m = 0). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  mat3 S = world_shape_operator(mat3(object.normal_matrix), v_normal, curv_d, curv_o);
  v_curv_d = vec3(S[0][0], S[1][1], S[2][2]);
  v_curv_o = vec3(S[0][1], S[0][2], S[1][2]);
  v_color = col;
  v_paint = paint;
  v_tint = tint;
  gl_Position = frame.view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
/* near(M) of a row (a slot's lights; the world's at slot + slots), linear in M over [0.25, 1]
 * (physics/lut.py image_space_tables). */
vec3 near_field(int slot, float M)
{
  int n = textureSize(near_lut, 0).x;
  float x = clamp((M - 0.25) / 0.75, 0.0, 1.0) * float(n - 1);
  int i0 = int(floor(x));
  int i1 = min(i0 + 1, n - 1);
  return mix(texelFetch(near_lut, ivec2(i0, slot), 0).rgb, texelFetch(near_lut, ivec2(i1, slot), 0).rgb,
             x - float(i0));
}

void main()
{
  vec3 n = normalize(v_normal);
  vec3 n_g = cross(dFdx(v_world), dFdy(v_world)); /* the facet's plane; derivatives before any discard */
  mat3 S = shape_operator(v_curv_d, v_curv_o); /* the normal field, for oblique_cosine */
  if (!facing_out(object.shading)) {
    n = -n;
    S = -S;
  }
  int slot = material_slot(object.shading.x);
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, v_world);
  float cos_o = max(dot(n, to_eye), 0.0);
  float m = (slot >= 0) ? v_paint.x : 0.0;
  vec3 modulation = v_paint.z * v_tint; /* M_i: glow and tint */
  if (mode == 0) {
    vec3 lambert = v_color * world_irradiance(n, LAMBERT_KERNEL) / PI; /* rho L_world for a uniform world */
    vec3 sss = vec3(0.0);
    if (slot >= 0) {
      float eta = materials.params[2 * slot].w;
      float F_r = fresnel_dielectric(cos_o, eta);
      int slots = textureSize(near_lut, 0).y / 2;
      float M = clamp(v_paint.y, 0.25, 1.0);
      /* the world's reflection F_r L_w is the surface layer's (pipeline/surface_layer.glsl) */
      sss = (1.0 - F_r) / PI * world_irradiance(n, materials.params[2 * slot + 1].xyz) * near_field(slots + slot, M) *
            angular_weight(slot, cos_o) * modulation;
    }
    out_color = vec4(mix(lambert, sss, m), 1.0);
    return;
  }
  vec3 to_light;
  vec3 radiance = emitter_irradiance(v_world, to_light);
  float cos_i = dot(n, to_light);
  if (cos_i <= 0.0 || max(radiance.r, max(radiance.g, radiance.b)) <= 0.0) {
    discard;
  }
  /* A facet that faces away from the light is in its own shadow (a closed surface's ray towards the
   * light enters the object), whatever its interpolated normal says: a shadow map's normal offset lets
   * it through near the terminator, the dipole model and Cycles' shadow rays do not. */
  if (dot(n_g, to_light) * dot(n_g, n) <= 0.0) {
    discard;
  }
  vec3 V = radiance * visibility(v_world, n);
  vec3 lambert = v_color * V * cos_i / PI;
  vec3 sss = vec3(0.0);
  if (slot >= 0) {
    vec4 mat = materials.params[2 * slot];
    float eta = mat.w;
    float M = clamp(v_paint.y, 0.25, 1.0);
    /* the light entering at an angle, read where it entered (common/oblique_entry.glsl) */
    vec3 E = V * oblique_cosine(n, to_light, eta, materials.entry[slot].xyz / mat.x, S);
    vec3 entering = (1.0 - fresnel_dielectric(cos_i, eta)) * angular_weight(slot, cos_i);
    /* The near field's light leans away from where it entered (physics/exit_lean.py near_constant): over a disk
     * lit by E + grad E . (x - x_o) it sends -K (w_o . grad E) more towards the eye, grad E = V S l the surface
     * gradient of the light's cosine (the normal field's), K per world unit; at most what the disk sends. */
    vec3 grad_mu = S * to_light;
    grad_mu -= n * dot(n, grad_mu);
    vec3 near = E * near_field(slot, M);
    near = max(near - V * (materials.lean[slot].xyz / mat.x) * dot(to_eye, grad_mu), vec3(0.0));
    sss = (1.0 - fresnel_dielectric(cos_o, eta)) / PI * near * entering * angular_weight(slot, cos_o) *
          modulation;
  }
  out_color = vec4(mix(lambert, sss, m), 0.0);
}
#endif
