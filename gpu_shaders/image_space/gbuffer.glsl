/* IMAGE_SPACE pass 2 (Shah 6.4.1): camera-view world positions x_o and the object's tag (common.glsl: 0 for
 * other surfaces, which occlude), and the facet normal at x_o (for the splats' partition). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  gl_Position = frame.view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  out_pos_id = vec4(v_world, object.shading.x);
  out_normal = vec4(normalize(cross(dFdx(v_world), dFdy(v_world))), 0.0);
}
#endif
