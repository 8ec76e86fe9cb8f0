/* One of the surface layer's full-screen images onto the frame, pixel for pixel: its factor (blended MULTIPLY:
 * the light below the specular layer times the colour texture, the layering weight and a normal map's share of
 * the entering light), then its gloss
 * (blended ADDITIVE). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  gl_Position = vec4(corner, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  vec4 value = texelFetch(layer, ivec2(gl_FragCoord.xy), 0);
  if (offset > 0.0) {
    /* the light entering through a normal map over the light the methods let in (surface_layer.glsl's entry) */
    vec2 entry = texelFetch(entry_map, ivec2(gl_FragCoord.xy), 0).xy;
    float ratio = entry.y > 0.0 ? clamp(entry.x / entry.y, 0.0, 4.0) : 1.0;
    value.rgb = (value.rgb + offset) * ratio - offset;
  }
  /* the factor is stored less 1 (offset 1), its alpha is a mask: the frame's alpha is kept (times 1) */
  out_color = offset > 0.0 ? vec4(value.rgb + offset, 1.0) : vec4(value.rgb, 0.0);
}
#endif
