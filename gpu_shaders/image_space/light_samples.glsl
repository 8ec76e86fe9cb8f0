/* IMAGE_SPACE pass 1 (Shah 6.4.1): light-view samples x_i. Every surface is drawn (other
 * objects occlude: shadows); subsurface surfaces store their position and tag (common.glsl), and the
 * power entering through their texel, Phi = E F_t(w_i) dA (point: I F_t dw_texel; directional:
 * E F_t texel area), times mm per unit^2 (dA in mm^2), the mask, M_i and the angular law's a(cos_i)
 * (common/angular_law.glsl); alpha holds M_d. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  mat3 S = world_shape_operator(mat3(object.normal_matrix), v_normal, curv_d, curv_o);
  v_curv_d = vec3(S[0][0], S[1][1], S[2][2]);
  v_curv_o = vec3(S[0][1], S[0][2], S[1][2]);
  v_paint = paint;
  v_tint = tint;
  gl_Position = light.face_view_proj[face] * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
const float MIN_FACET_COS = 0.05;
void main()
{
  int slot = material_slot(object.shading.x);
  if (slot < 0) {
    out_pos_id = vec4(0.0);
    out_flux = vec4(0.0);
    return;
  }
  vec4 mat = materials.params[2 * slot];
  vec3 n = normalize(v_normal);
  vec3 to_light;
  vec3 radiance = emitter_irradiance(v_world, to_light);
  /* The texel's power passes through the true (flat) surface, of area dw d^2 / cos_g; it enters
   * with the shading normal's cosine, as the near field and the dipole model take it:
   * E dA = (I / d^2) cos_s (d^2 dw / cos_g). Facets nearly edge-on are capped (sparse there). */
  float cos_s = dot(n, to_light);
  float cos_g = abs(dot(normalize(cross(dFdx(v_world), dFdy(v_world))), to_light));
  float cos_i = max(cos_s, 0.0);
  /* the light entering at an angle, read where it entered (common/oblique_entry.glsl): its cosine per channel */
  vec3 entering = oblique_cosine(n, to_light, mat.w, materials.entry[slot].xyz / mat.x,
                                 shape_operator(v_curv_d, v_curv_o));
  vec3 shading = entering / max(cos_g, MIN_FACET_COS);
  float measure;
  if (light.position_kind.w < 0.5) {
    measure = light.shadow.y; /* texel area, world units^2 */
    radiance = light.radiance.rgb;
  }
  else {
    /* Solid angle of this texel of a square face of half angle atan(t) (t = 1: a cube face);
     * intensity without the 1/d^2. */
    float texels = light.shadow.x;
    float t = light.shadow.z;
    vec2 in_face = mod(gl_FragCoord.xy, texels) / texels * 2.0 - 1.0;
    measure = light.shadow.y / pow(1.0 + t * t * dot(in_face, in_face), 1.5);
    vec3 d = light.position_kind.xyz - v_world;
    radiance *= dot(d, d);
  }
  vec3 phi = radiance * (1.0 - fresnel_dielectric(cos_i, mat.w)) * shading * measure * mat.x * mat.x;
  phi *= v_paint.x * v_paint.z * v_tint * angular_weight(slot, cos_i); /* the angular law, entering */
  out_pos_id = vec4(v_world, object.shading.x);
  out_flux = vec4(phi, clamp(v_paint.y, 0.25, 1.0));
}
#endif
