/* Caustics pass 3 (Shah 5.3.3-5.3.5): per texel of a caster's vertex grid (one fragment per grid
 * vertex; with dispersion three tiles, one per channel and index), refract (or mirror) the light,
 * find where the ray leaves the caster (back-face map) and meets the receivers (receiver atlas) by
 * the intersection estimate, and write the landing point and the flux it carries.
 * NumPy twin: techniques/caustics/model.py. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  gl_Position = vec4(corner, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
/* The positions texture of Eq. 5.3: which = 0 the caster's back faces (grid projection), 1 the
 * receivers (light atlas). False where the map holds nothing (a null look-up, Shah 5.3.4). */
bool positions_lookup(int which, vec3 p, out vec3 y, out ivec2 texel)
{
  vec4 value;
  if (which == 0) {
    vec4 clip = caustic.grid_view_proj * vec4(p, 1.0);
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    int G = int(caustic.grid.x + 0.5);
    if (clip.w <= 0.0 || any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) {
      return false;
    }
    texel = clamp(ivec2(floor(uv * float(G))), ivec2(0), ivec2(G - 1));
    value = texelFetch(back_position, texel, 0);
  }
  else {
    int face;
    vec2 uv;
    int texels = int(caustic.estimate.z + 0.5);
    if (!light_atlas_uv(p, texels, face, uv)) {
      return false;
    }
    texel = light_atlas_texel(face, uv, texels);
    value = texelFetch(receiver_atlas, texel, 0);
  }
  y = value.xyz;
  return value.w > 0.5;
}

/* Shah Eq. 5.1-5.4 with the oscillation guard of 5.3.4 (estimate_intersection in the twin):
 * d_0 = |y(v) - v|, d_{k+1} = |y(v + d_k r) - v|; once g(d) = d_{k+1} - d_k has changed sign the
 * two estimates bracket the root, and a step leaving the bracket or not shrinking |g| bisects.
 * Secant steps (estimate.y >= 1.5) replace d_{k+1}, after the first, by the root of the line
 * through the last two (d, g). */
bool estimate_intersection(int which, vec3 v, vec3 r, out vec3 y, out ivec2 texel)
{
  if (!positions_lookup(which, v, y, texel)) {
    return false;
  }
  float d = length(y - v);
  float lo = -1.0e30, hi = 1.0e30, g_prev = 1.0e30;
  float d_last = 0.0, g_last = 0.0;
  bool guard = caustic.estimate.y > 0.5;
  bool secant = caustic.estimate.y > 1.5;
  int iterations = max(int(caustic.estimate.x + 0.5), 1);
  for (int k = 0; k < iterations; k++) {
    vec3 y_k;
    ivec2 texel_k;
    if (!positions_lookup(which, v + d * r, y_k, texel_k)) {
      return false;
    }
    texel = texel_k;
    y = y_k;
    float d_new = length(y_k - v);
    float g = d_new - d;
    if (secant) {
      float slope = (k > 0 && d != d_last) ? (g - g_last) / (d - d_last) : 0.0;
      if (abs(slope) > 1.0e-12) {
        d_new = d - g / slope;
      }
      d_last = d;
      g_last = g;
    }
    if (guard) {
      if (g > 0.0) {
        lo = max(lo, d);
      }
      if (g < 0.0) {
        hi = min(hi, d);
      }
      if (lo > -1.0e30 && hi < 1.0e30 && (d_new <= lo || d_new >= hi || abs(g) >= g_prev)) {
        d_new = 0.5 * (lo + hi);
      }
    }
    g_prev = abs(g);
    d = d_new;
  }
  return true;
}

void main()
{
  out_landing = vec4(0.0);
  out_flux = vec4(0.0);
  int G = int(caustic.grid.x + 0.5);
  ivec2 px = ivec2(gl_FragCoord.xy);
  int channel = px.x / G;
  ivec2 t = ivec2(px.x - channel * G, px.y);
  vec4 front = texelFetch(front_position, t, 0);
  if (front.w < 0.5) {
    return; /* no caster on this grid vertex */
  }
  vec3 v = front.xyz;
  vec3 n = normalize(texelFetch(front_normal, t, 0).xyz);
  /* Flux through the texel: the light's irradiance times the texel's area across the beam, or its
   * intensity times the texel's solid angle (caustics/model.py CasterGrid.texel_flux_factor). */
  float a = 2.0 * caustic.grid.y / float(G);
  vec3 d;
  vec3 flux;
  if (light.position_kind.w < 0.5) {
    d = light.direction.xyz;
    flux = light.radiance.rgb * a * a;
  }
  else {
    d = normalize(v - light.position_kind.xyz);
    vec2 ndc = (vec2(t) + 0.5) / float(G) * 2.0 - 1.0;
    float u2 = dot(ndc, ndc) * caustic.grid.y * caustic.grid.y;
    flux = light.radiance.rgb * emitter_lobe(d) * a * a / pow(1.0 + u2, 1.5);
  }
  if (dot(n, d) > 0.0) {
    n = -n;
  }
  flux *= visibility(v, n); /* another object between the light and the caster (the shadow map) */
  float eta = caustic.grid.w;
  if (caustic.estimate.w > 1.5) { /* dispersion: this tile carries one channel at its own index */
    flux *= vec3(channel == 0, channel == 1, channel == 2);
    eta += float(channel - 1) * caustic.absorption.w;
  }
  int surfaces = int(caustic.grid.z + 0.5);
  vec3 r;
  if (surfaces == 0) {
    r = reflect(d, n);
    flux *= caustic.tint.rgb;
  }
  else {
    flux *= 1.0 - fresnel_dielectric(-dot(d, n), eta);
    r = refract(d, n, 1.0 / eta);
    if (surfaces == 2) { /* out through the back faces (Wyman 2005 in the light's view) */
      vec3 exit_p;
      ivec2 exit_texel;
      if (!estimate_intersection(0, v, r, exit_p, exit_texel)) {
        return;
      }
      vec3 nb = normalize(texelFetch(back_normal, exit_texel, 0).xyz);
      if (dot(nb, r) > 0.0) {
        nb = -nb;
      }
      vec3 r2 = refract(r, nb, eta);
      if (dot(r2, r2) == 0.0) {
        return; /* total internal reflection: this light stays inside */
      }
      flux *= (1.0 - fresnel_dielectric(-dot(r, nb), 1.0 / eta)) * exp(-caustic.absorption.rgb * length(exit_p - v));
      v = exit_p;
      r = r2;
    }
  }
  vec3 y;
  ivec2 landing_texel;
  if (!estimate_intersection(1, v, r, y, landing_texel)) {
    return;
  }
  y = v + length(y - v) * r; /* on the ray at the estimated distance, not snapped to the map's texel */
  if (surfaces == 1) { /* one surface (water): attenuated down to the receiver (Shah 5.3.5) */
    flux *= exp(-caustic.absorption.rgb * length(y - v));
  }
  out_landing = vec4(y, 1.0);
  out_flux = vec4(flux, 0.0);
}
#endif
