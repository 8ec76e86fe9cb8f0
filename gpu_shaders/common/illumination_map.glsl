/* TEXTURE_SPACE illumination map (Lensch Sec. 6.1, Eq. 3): one point per texel of the atlas,
 * lit at the texel's surface point x_c with its normal. mode 0: the world, E_sh(n) in spherical
 * harmonics through the boundary (pi L_w (1 - F_dr,in) for a uniform world) times the sky the point
 * sees past its object (``sky``: geometry/world_visibility.py; 1 where not baked); mode 1: one
 * emitter, E = L cos_i (1 - F_r(cos_i)) V, added.
 * Border texels carry their source's point, so they take the irradiance across the seam.
 * As in the base pass, a point whose facet faces away from the light is in shadow. An emitter's light
 * entering at an angle is read where it entered (common/oblique_entry.glsl; ``entry`` the shift per channel in
 * world units, 0 for none; curv_d, curv_o the texel's shape operator in object space). An emitter's E is
 * scaled by cosine_table(cos_i), an n x 1 table read with linear interpolation (``cosine_lerp``), the world's by
 * its last texel (one texel of 1 leaves E; TEXTURE_SPACE's emitters: the angular law, physics/angular_law.py;
 * QUADGRAPH's exitance loss pass: physics/single_scattering.exitance_loss). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  v_world = (object.model * vec4(pos, 1.0)).xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  mat3 S = world_shape_operator(mat3(object.normal_matrix), v_normal, curv_d, curv_o);
  v_curv_d = vec3(S[0][0], S[1][1], S[2][2]);
  v_curv_o = vec3(S[0][1], S[0][2], S[1][2]);
  v_normal = normalize(v_normal);
  v_facet = mat3(object.normal_matrix) * facet;
  v_sky = sky;
  gl_Position = vec4((texel + 0.5) / atlas_size * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  int n = textureSize(cosine_table, 0).x;
  if (mode == 0) {
    /* the world has no one cosine: the table's value at normal incidence (its only texel for
     * QUADGRAPH's flat-face loss R) */
    out_irradiance = vec4(v_sky * world_irradiance(v_normal, world_kernel) *
                          texelFetch(cosine_table, ivec2(n - 1, 0), 0).rgb, 1.0);
    return;
  }
  vec3 to_light;
  vec3 radiance = emitter_irradiance(v_world, to_light);
  float cos_i = dot(v_normal, to_light);
  if (cos_i <= 0.0 || dot(v_facet, to_light) <= 0.0) {
    discard;
  }
  vec3 E = radiance * oblique_cosine(v_normal, to_light, eta, entry, shape_operator(v_curv_d, v_curv_o)) *
           (1.0 - fresnel_dielectric(cos_i, eta)) * visibility(v_world, v_normal);
  out_irradiance = vec4(E * cosine_lerp(cosine_table, cos_i), 0.0);
}
#endif
