/* IMAGE_SPACE final pass: adds F_t(w_o) / pi * a(cos_o) * S(x_o) * m, the splatted far field with the angular
 * law's weight of the light leaving (common/angular_law.glsl), to the
 * subsurface objects' pixels (additive over the base pass, depth-tested against it). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  v_paint = paint;
  gl_Position = frame.view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  int slot = material_slot(object.shading.x);
  vec3 n = normalize(v_normal);
  if (!facing_out(object.shading)) {
    n = -n;
  }
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, v_world);
  float eta = materials.params[2 * slot].w;
  vec3 S = texelFetch(scatter, ivec2(gl_FragCoord.xy), 0).rgb;
  float cos_o = max(dot(n, to_eye), 0.0);
  out_color = vec4((1.0 - fresnel_dielectric(cos_o, eta)) / PI * angular_weight(slot, cos_o) * S * v_paint.x, 0.0);
}
#endif
