/* Caustics pass 1 (Shah 5.3.2): world positions of the receivers seen from the light, into one face
 * of the 3 x 2 receiver atlas (the shadow atlas's layout and projections); w = 1 where a receiver
 * was drawn, 0 (cleared) where the light sees none. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  gl_Position = light.face_view_proj[face] * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  out_position = vec4(v_world, 1.0);
}
#endif
