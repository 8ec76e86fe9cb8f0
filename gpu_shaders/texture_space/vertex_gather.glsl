/* TEXTURE_SPACE vertex gather (Lensch Eq. 10 and Sec. 5.4): three points per surface texel, one
 * per vertex of its proxy triangle, each adding psi~_v A E to E^g_v and w_v E to B^d_v
 * (additive blending into a texture of one texel per vertex). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec3 E = texelFetch(irradiance, ivec2(texel), 0).rgb;
  v_eg = dual * E;
  v_bd = blend * E;
  int v = int(target + 0.5);
  vec2 pixel = vec2(v % vertex_width, v / vertex_width) + 0.5;
  gl_Position = vec4(pixel / vertex_size * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  out_eg = vec4(v_eg, 0.0);
  out_bd = vec4(v_bd, 0.0);
}
#endif
