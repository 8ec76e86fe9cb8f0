/* Caustics pass 4 (Shah 5.3.3, 5.3.6): one Gaussian point splat per traced grid vertex (instanced
 * quads), adding its flux into the caustic atlas at the texel where it landed; each Gaussian is
 * normalised so the atlas holds flux per texel. Adaptive splats (on by default) widen each
 * Gaussian to half the spacing of its neighbours' landing points, which closes the gaps of a
 * coarse grid (Shah Fig. 5.11) without blurring where rays converge; otherwise sigma is fixed. */
#ifdef GPU_VERTEX_SHADER
/* Landing point of trace texel t in continuous atlas texels; false if none. */
bool landing(ivec2 t, out vec2 at, out int face)
{
  vec4 l = texelFetch(trace_landing, t, 0);
  if (l.w < 0.5) {
    return false;
  }
  int texels = int(caustic.estimate.z + 0.5);
  vec2 uv;
  if (!light_atlas_uv(l.xyz, texels, face, uv)) {
    return false;
  }
  at = vec2(face % 3, face / 3) * float(texels) + uv * float(texels);
  return true;
}

void main()
{
  int G = int(caustic.grid.x + 0.5);
  int width = textureSize(trace_landing, 0).x;
  ivec2 t = ivec2(gl_InstanceID % width, gl_InstanceID / width);
  v_flux = texelFetch(trace_flux, t, 0).rgb;
  int face;
  vec2 at;
  if (!landing(t, at, face) || max(v_flux.r, max(v_flux.g, v_flux.b)) <= 0.0) {
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0); /* nothing landed: outside the clip volume */
    return;
  }
  float sigma = caustic.splat.x;
  if (caustic.splat.y > 0.5) {
    float spacing = 0.0;
    int tile_end = (t.x / G + 1) * G;
    ivec2 neighbours[2] = ivec2[2](ivec2(t.x + 1, t.y), ivec2(t.x, t.y + 1));
    for (int k = 0; k < 2; k++) {
      ivec2 q = neighbours[k];
      vec2 at_q;
      int face_q;
      if (q.x < tile_end && q.y < G && landing(q, at_q, face_q) && face_q == face) {
        spacing = max(spacing, length(at_q - at));
      }
    }
    sigma = clamp(0.5 * spacing, caustic.splat.x, caustic.splat.z);
  }
  int texels = int(caustic.estimate.z + 0.5);
  v_centre = at;
  v_sigma = sigma;
  v_tile = vec2(face % 3, face / 3);
  vec2 atlas_size = vec2(3.0, 2.0) * float(texels);
  vec2 p = at + corner * 3.5 * sigma;
  gl_Position = vec4(p / atlas_size * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  int texels = int(caustic.estimate.z + 0.5);
  if (any(notEqual(floor(gl_FragCoord.xy / float(texels)), v_tile))) {
    discard; /* keep the splat on its own face */
  }
  vec2 delta = gl_FragCoord.xy - v_centre;
  float s2 = v_sigma * v_sigma;
  out_flux = vec4(v_flux * exp(-0.5 * dot(delta, delta) / s2) / (2.0 * PI * s2), 0.0);
}
#endif
