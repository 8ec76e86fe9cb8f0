/* IMAGE_SPACE temporal accumulation of the splatted far field (our replacement for Shah 6.5.2's
 * sample reuse, which measured no less flicker on a turning object): each pixel's surface point
 * is carried back through its object's motion into the previous frame; where the previous frame
 * saw the same surface there, the result is mix(previous, current, blend), else the current. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  gl_Position = vec4(corner, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec4 current = texelFetch(scatter, pixel, 0);
  vec4 here = texelFetch(gbuffer, pixel, 0);
  out_accum = current;
  /* the object's number from its tag (common.glsl); past the block's 32 objects, no history */
  int slot = int(here.w + 0.5) / 64 - 1;
  if (here.w < 0.5 || slot >= 32) {
    return;
  }
  vec4 previous_world = temporal.previous_model[slot] * (temporal.inverse_model[slot] * vec4(here.xyz, 1.0));
  vec4 clip = temporal.previous_view_proj * previous_world;
  if (clip.w <= 0.0) {
    return;
  }
  vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
  ivec2 size = textureSize(previous_gbuffer, 0);
  ivec2 before = ivec2(floor(uv * vec2(size)));
  if (any(lessThan(before, ivec2(0))) || any(greaterThanEqual(before, size))) {
    return;
  }
  vec4 seen = texelFetch(previous_gbuffer, before, 0);
  if (abs(seen.w - here.w) > 0.5 || distance(seen.xyz, previous_world.xyz) > temporal.tolerance.x) {
    return; /* disoccluded, or another surface: no history */
  }
  out_accum = mix(texelFetch(previous_accum, before, 0), current, blend);
}
#endif
