/* Caustics pass 2 (Shah 5.3.2): a caster's world positions and outward normals on its vertex grid,
 * seen from the light. Drawn twice: nearest surfaces (front) and, with the depth test reversed,
 * farthest ones (back, for refraction through two surfaces). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  gl_Position = caustic.grid_view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  out_position = vec4(v_world, 1.0);
  out_normal = vec4(normalize(v_normal), 0.0);
}
#endif
