/* GEOCUBE pass (Chan & Wang 2005, Sec. 2-3): per fragment of a front face, Fresnel reflection of the
 * environment; refraction in, the cone-propelled exit search, refraction out or one total internal
 * reflection and a second search; the environment in the leaving direction, blurred by the slab
 * transfer fit for the scattering depth tau = sigma_s L (f_t G_theta_bar + c_t, Sec. 3.3, plus the
 * unscattered e^-tau) and dimmed by coloured Beer absorption e^(-sigma_a L).
 * Output modes (gc.table.z), for tests: 0 colour; 1 entry point (bake frame) and steps of the first
 * leg; 2 first exit point and premature flag; 3 refracted direction (bake frame) and starting cube; in world
 * space: 4 entry point, 5 refracted direction, 6 last exit point and the legs inside (1, or 2 after a total
 * internal reflection), 7 leaving direction and T_2. */

/* The key filtered environment at blur width theta (radians): fractional level by piecewise-linear
 * interpolation in the levels' sigma, bilinear in each level (bake/environment.sample twin). */
vec3 env_sample(vec3 d, float theta)
{
  int levels = int(gc.params.w + 0.5);
  float f = float(levels - 1);
  for (int l = 0; l < levels - 1; l++) {
    float s0 = gc.env_levels[l].x;
    float s1 = gc.env_levels[l + 1].x;
    if (theta < s1) {
      f = float(l) + clamp((theta - s0) / max(s1 - s0, 1e-12), 0.0, 1.0);
      break;
    }
  }
  int l0 = int(floor(f));
  int l1 = min(l0 + 1, levels - 1);
  float t = f - float(l0);
  vec3 a = atlas_bilinear(env_atlas, int(gc.env_levels[l0].z + 0.5), d, int(gc.env_levels[l0].y + 0.5)).rgb;
  vec3 b = atlas_bilinear(env_atlas, int(gc.env_levels[l1].z + 0.5), d, int(gc.env_levels[l1].y + 0.5)).rgb;
  return mix(a, b, t);
}

/* The slab transfer fit at scattering depth tau: (f_t, theta_bar, c_t, c_r), linear in
 * s = log(1 + tau) / log(1 + tau_max) (techniques/geocube/model.py transfer_image). */
vec4 transfer(float tau)
{
  float n = gc.table.y;
  float x = clamp(log(1.0 + tau) / gc.table.x, 0.0, 1.0) * (n - 1.0);
  int i = min(int(floor(x)), int(n) - 2);
  return mix(texelFetch(transfer_table, ivec2(i, 0), 0), texelFetch(transfer_table, ivec2(i + 1, 0), 0),
             x - float(i));
}

#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  v_cube = int(start_cube + 0.5);
  gl_Position = frame.view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  float eta = gc.sigma_a.w;
  vec3 n = normalize(v_normal);
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, v_world);
  if (dot(n, to_eye) < 0.0) {
    n = -n; /* a back face seen through a hole, or a normal that disagrees with the winding */
  }
  float cos_i = max(dot(n, to_eye), 0.0);
  float F_1 = fresnel_dielectric(cos_i, eta);
  vec3 reflected = env_sample(reflect(-to_eye, n), 0.0);

  mat3 to_bake = mat3(gc.bake_from_world);
  vec3 p1 = (gc.bake_from_world * vec4(v_world, 1.0)).xyz;
  vec3 r1 = normalize(to_bake * refract(-to_eye, n, 1.0 / eta));
  int mode = int(gc.table.z + 0.5);
  if (mode == 3) {
    out_color = vec4(r1, float(v_cube));
    return;
  }
  if (mode == 4) {
    out_color = vec4(v_world, 0.0);
    return;
  }
  if (mode == 5) {
    out_color = vec4(normalize(mat3(gc.world_from_bake) * r1), 0.0);
    return;
  }
  int cube = v_cube;
  vec3 N2;
  int steps;
  bool premature;
  vec3 p2 = gc_exit(p1, r1, cube, true, N2, steps, premature);
  if (mode == 1) {
    out_color = vec4(p1, float(steps));
    return;
  }
  if (mode == 2) {
    out_color = vec4(p2, premature ? 1.0 : 0.0);
    return;
  }
  float L = length(p2 - p1);
  vec3 p_last = p2;
  float legs = 1.0;
  /* Out through the back (Snell, relative index 1 / eta seen from inside), or one total internal
   * reflection and a second search (Sec. 2). */
  vec3 r_out = refract(r1, -N2, eta);
  float T_2 = 1.0 - fresnel_dielectric(dot(r1, N2), 1.0 / eta);
  if (dot(r_out, r_out) < 1e-12) {
    vec3 r2 = reflect(r1, N2);
    vec3 N3;
    int steps2;
    bool premature2;
    vec3 p3 = gc_exit(p2, r2, cube, false, N3, steps2, premature2);
    L += length(p3 - p2);
    p_last = p3;
    legs = 2.0;
    r_out = refract(r2, -N3, eta);
    T_2 = 1.0 - fresnel_dielectric(dot(r2, N3), 1.0 / eta);
    if (dot(r_out, r_out) < 1e-12) {
      r_out = r2; /* a second total reflection: the paper stops at one; leave along the last ray */
      T_2 = 1.0;
    }
  }
  vec3 d_out = normalize(mat3(gc.world_from_bake) * r_out);
  if (mode == 6) {
    vec3 p_world = (gc.world_from_bake * vec4(p_last, 1.0)).xyz;
    out_color = vec4(p_world, legs);
    return;
  }
  if (mode == 7) {
    out_color = vec4(d_out, T_2);
    return;
  }
  vec3 beer = exp(-gc.sigma_a.rgb * L);
  vec3 tau = gc.sigma_s.rgb * L;
  vec3 sharp = env_sample(d_out, 0.0);
  vec3 C_A = gc.env_mean.rgb;
  vec3 transmitted;
  vec3 back_scattered;
  for (int k = 0; k < 3; k++) {
    vec4 fit = transfer(tau[k]);
    vec3 blurred = env_sample(d_out, fit.y);
    transmitted[k] = exp(-tau[k]) * sharp[k] + fit.x * blurred[k] + fit.z * C_A[k];
    back_scattered[k] = fit.w * C_A[k];
  }
  vec3 color = F_1 * reflected + (1.0 - F_1) * beer * (T_2 * transmitted + back_scattered);
  out_color = vec4(color, 1.0);
}
#endif
