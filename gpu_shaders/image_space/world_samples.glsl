/* IMAGE_SPACE world samples (Shah 6.4.2): layer `layer` of a depth peel of the subsurface meshes
 * along one axis (orthographic `view_proj`): the nearest surface beyond the previous layer's. Each
 * stores its position and tag (common.glsl), and the world's power entering through its texel,
 * Phi = E_sh(n) texel_area / (|n_g.x| + |n_g.y| + |n_g.z|) (mm^2): the texel covers
 * texel_area / |n_g . a| of the facet, and the three axes share it by |n_g . a| / sum |n_g . b|. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  v_paint = paint;
  v_tint = tint;
  gl_Position = view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  int slot = material_slot(object.shading.x);
  if (slot < 0) {
    discard;
  }
  if (layer > 0) {
    vec4 previous = texelFetch(previous_pos_id, ivec2(gl_FragCoord.xy), 0);
    if (previous.w < 0.5) {
      discard; /* nothing was in front: nothing lies behind */
    }
    vec4 c = view_proj * vec4(previous.xyz, 1.0);
    if (gl_FragCoord.z <= (c.z / c.w) * 0.5 + 0.5 + depth_epsilon) {
      discard; /* peeled already */
    }
  }
  vec4 mat = materials.params[2 * slot];
  vec3 n_g = abs(normalize(cross(dFdx(v_world), dFdy(v_world))));
  vec3 phi = world_irradiance(normalize(v_normal), materials.params[2 * slot + 1].xyz) * texel_area / max(n_g.x + n_g.y + n_g.z, 1.0);
  phi *= mat.x * mat.x * v_paint.x * v_paint.z * v_tint;
  out_pos_id = vec4(v_world, object.shading.x);
  out_flux = vec4(phi, clamp(v_paint.y, 0.25, 1.0));
}
#endif
