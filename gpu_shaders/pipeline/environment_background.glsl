/* The world's environment image behind everything (drawn first, at the far plane), from level 0 of
 * the key filtered chain: what a camera ray that hits nothing sees, as in Cycles. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  v_ndc = corner;
  gl_Position = vec4(corner, 1.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  mat4 inv = inverse(frame.view_proj);
  vec4 a = inv * vec4(v_ndc, -1.0, 1.0);
  vec4 b = inv * vec4(v_ndc, 1.0, 1.0);
  vec3 d = normalize(b.xyz / b.w - a.xyz / a.w);
  out_color = vec4(atlas_bilinear(env_atlas, env_res, d, 0).rgb, 1.0);
}
#endif
