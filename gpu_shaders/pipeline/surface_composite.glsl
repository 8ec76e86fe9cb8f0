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
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec3 entry = texelFetch(entry_map, p, 0).xyz;
    vec2 sum = entry.xy;
    if (entry.z >= 1.0) {
      /* under a medium the light a bump lets in leaves spread over its diffusion length: both sums averaged over a
       * disk of that radius (a golden-angle spiral of 16 taps) on the same surface (depth within 5 %) */
      float depth = texelFetch(gbuffer_map, p, 0).w;
      float radius = min(entry.z, 16.0);
      ivec2 size = textureSize(entry_map, 0);
      for (int k = 1; k < 16; k++) {
        float r = radius * sqrt((float(k) + 0.5) / 16.0);
        float a = 2.39996323 * float(k);
        ivec2 q = clamp(p + ivec2(round(r * vec2(cos(a), sin(a)))), ivec2(0), size - 1);
        if (abs(texelFetch(gbuffer_map, q, 0).w - depth) <= 0.05 * depth) {
          sum += texelFetch(entry_map, q, 0).xy;
        }
      }
    }
    float ratio = sum.y > 0.0 ? clamp(sum.x / sum.y, 0.0, 4.0) : 1.0;
    value.rgb = (value.rgb + offset) * ratio - offset;
  }
  /* the factor is stored less 1 (offset 1), its alpha is a mask: the frame's alpha is kept (times 1) */
  out_color = offset > 0.0 ? vec4(value.rgb + offset, 1.0) : vec4(value.rgb, 0.0);
}
#endif
