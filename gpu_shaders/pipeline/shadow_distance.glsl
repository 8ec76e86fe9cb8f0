/* Shadow pass: distance from the emitter into one face of the R32F atlas.
 * Point emitters store |p - light|; directional ones the depth along the axis
 * from the shadow origin. The base pass compares against the same quantity. */
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
  if (light.position_kind.w < 0.5) {
    out_distance = dot(v_world - light.position_kind.xyz, light.direction.xyz);
  }
  else {
    out_distance = length(v_world - light.position_kind.xyz);
  }
}
#endif
