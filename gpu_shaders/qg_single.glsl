/* QUADGRAPH surface term (physics/single_scattering.py): the response of the surface to the light
 * entering it, which the diffusion draws Lambertian and without its first order (Wang Sec. 7 leaves
 * low-order scattering out), added per emitter into a screen target that qg_display adds to the
 * diffusion's radiance. mode 0 lays down the depth of the nearest QUADGRAPH surface, zero colour and
 * its distance from the eye in alpha; mode 2 keeps, per pixel, the distance of the nearest surface
 * behind that one (``depths`` is mode 0's target): where the view ray leaves the medium again.
 * mode 1 draws ``terms`` (bit 1: single scattering, bit 2: local multiple scattering):
 * - single scattering L^(1) (Jensen et al. 2001): the refracted view ray marched at t_k = t_end (k / N)^2,
 *   t_end the lesser of TAU_MAX optical depths and the exit (``depths`` is mode 2's target), taking at
 *   each node the path d the light has crossed in the medium from the emitter's distance map (the
 *   first surface the light meets to the node, in a straight line), and integrating
 *   sigma_s p E exp(-sigma_t (t + d)) per segment with the exponent linear; into the medium, the
 *   normal-incidence 1 - F_0 (the entry point's normal is not in the map);
 * - local multiple scattering L^(ms): Chandrasekhar's lit half-space less its first order at the
 *   pixel's own surface point, with q's visibility and 1 - F_r(mu_i) into the medium, its cosine the
 *   lateral average of the clamped ramp the curved surface sees (physics/terminator.py).
 * Both leave through T_o = 1 - F_r(mu_o). sigma_a, sigma_s: rgb per world unit, in vec4s. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  gl_Position = frame.view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
/* Path length in the medium from the first surface the emitter's light meets to p: the distance
 * atlas (shadow_distance.glsl) holds that surface's distance, interpolated bilinearly over those of
 * the four nearest texels that saw a surface not far behind p (a nearest texel steps the path at
 * grazing light; a texel beside the outline that missed the object or saw the floor behind it would
 * light p in full: speckled rims). "Far": 16 texel widths, the depth one texel spans on a surface the
 * light meets at 86 degrees. On the isolated back-lit bunny the term's RMSE against Cycles' single
 * scattering is 0.34 keeping every texel that saw a surface, 0.27 / 0.17 / 0.15 with 4 / 8 / 16 widths,
 * and 0.69 dropping every texel behind p (grazing rims 2.5 times too dark).
 * 0 where p lies in front of them, outside the map, or where no texel qualifies. */
float light_path(vec3 p)
{
  int texels = int(light.shadow.x);
  vec2 x;
  ivec2 tile;
  float here;
  if (!shadow_atlas_point(p, x, tile, here)) {
    return 0.0;
  }
  x -= 0.5;
  ivec2 base = ivec2(floor(x));
  vec2 f = x - vec2(base);
  float texel_world = shadow_texel_world(p - light.position_kind.xyz);
  float behind = here + 16.0 * texel_world;
  float stored = 0.0, weight = 0.0;
  for (int k = 0; k < 4; k++) {
    ivec2 o = ivec2(k & 1, k >> 1);
    float d = texelFetch(shadow_atlas, tile + clamp(base + o, ivec2(0), ivec2(texels - 1)), 0).r;
    float w = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y);
    if (d <= behind) {
      stored += w * d;
      weight += w;
    }
  }
  return weight > 0.0 ? max(here - stored / weight, 0.0) : 0.0;
}

/* Chandrasekhar's H(mu) of the medium's albedo alpha' per channel, linear in h_table (mu = k / (n - 1)). */
vec3 chandrasekhar_H(float mu)
{
  return table_lerp(h_table, mu);
}

/* The local multiple scattering L^(ms) of light entering at this pixel's surface point:
 * Chandrasekhar's half-space (single_scattering.multiple_half_space), at the refracted cosines between
 * the Fresnel transmittances, for the light entering per unit area T_i E mu_i (mu_i outside, as q); the
 * light's visibility as q's (ts_illumination); E and to_light: the emitter's at p. On a curved
 * surface mu_i is the effective cosine of physics/terminator.py per channel, mu_eff = max(mu_i, 0) + g rho G(mu_i / (g rho)), g = |grad_mu|
 * the surface gradient of the light's cosine: the lateral spread of the light entering beside the
 * terminator, which also lights the pixels just past it. There the light entered at about mu_eff
 * (H and T_i take the larger of the two) and its visibility is the terminator's, min(-mu_i / g, 8 rho)
 * along the gradient, tested along the light. Measured against the alternatives: one kernel radius
 * further into the lit side removes the black wedges a faceted ball's terminator leaves in this term
 * alone (its facets shadow the smooth terminator; the diffusion covers them in the image) but leaks
 * light into cast shadows (3 pixels inside the outline, the cow's RMSE 0.118 -> 0.142 where this
 * rule gave 0.132 -> 0.134, on other bakes); the pixel's own point tested along the light draws jagged
 * streaks. */
vec3 local_multiple(vec3 p, vec3 n, float mu_t, vec3 E, vec3 to_light, vec3 grad_mu)
{
  float mu_i = dot(n, to_light);
  float slope = length(grad_mu);
  /* The ramp holds while the kernel spans less than the curvature's radius: g rho at most 1 (mu_eff at
   * most 1 / pi at the terminator; a ball much smaller than rho averages max(0, cos) to 1 / 4), not
   * g rho / pi without bound on a low-poly mesh's sharp bends (the cow's normals turn by 0.14 / mm in
   * the median triangle, 1.2 / mm in one of a hundred). */
  vec3 scale = min(slope * terminator_rho.rgb, vec3(1.0)); /* terminator.SCALE_MAX */
  vec3 mu_eff;
  for (int c = 0; c < 3; c++) {
    float u = 0.5 + 0.5 * mu_i / (abs(mu_i) + scale[c] + 1e-30);
    mu_eff[c] = max(mu_i, 0.0) + scale[c] * table_lerp(terminator_table, u)[c];
  }
  if (max(mu_eff.r, max(mu_eff.g, mu_eff.b)) <= 0.0) {
    return vec3(0.0);
  }
  float vis;
  if (mu_i > 0.0) {
    vis = visibility(p, n);
  }
  else {
    float rho = max(terminator_rho.r, max(terminator_rho.g, terminator_rho.b));
    vis = visibility(p + grad_mu / slope * min(-mu_i / slope, 8.0 * rho), to_light);
  }
  vec3 sigma_s_prime = sigma_s.rgb * (1.0 - g);
  vec3 alpha_prime = sigma_s_prime / (sigma_a.rgb + sigma_s_prime);
  vec3 H_o = chandrasekhar_H(mu_t);
  vec3 L;
  for (int c = 0; c < 3; c++) {
    float mu_h = max(mu_i, mu_eff[c]);
    float mu_it = sqrt(1.0 - (1.0 - mu_h * mu_h) / (eta * eta));
    float T_i = 1.0 - fresnel_dielectric(mu_h, eta);
    L[c] = T_i * E[c] * alpha_prime[c] * mu_eff[c] * (chandrasekhar_H(mu_it)[c] * H_o[c] - 1.0) /
           (4.0 * PI * (mu_it + mu_t));
  }
  return vis * L;
}

float hg_phase(float cos_theta)
{
  float g2 = g * g;
  return (1.0 - g2) / (4.0 * PI * pow(max(1.0 + g2 - 2.0 * g * cos_theta, 1e-6), 1.5));
}

/* integral over [0, t_max] of sigma_s p E exp(-sigma_t (t + d)) along x_o + t w_t: per segment, the
 * source's mean at the ends times the exponential of the linear exponent, integrated exactly. */
vec3 march(vec3 x_o, vec3 w_t, float t_max, vec3 sigma_t)
{
  vec3 L = vec3(0.0);
  vec3 a_prev = vec3(0.0), f_prev = vec3(0.0);
  float t_prev = 0.0;
  for (int k = 0; k <= segments; k++) {
    float s = float(k) / float(segments);
    float t = t_max * s * s;
    vec3 x = x_o + t * w_t;
    vec3 to_light;
    vec3 E = emitter_irradiance(x, to_light);
    vec3 a = -sigma_t * (t + light_path(x));
    vec3 f = sigma_s.rgb * hg_phase(dot(to_light, w_t)) * E;
    if (k > 0) {
      vec3 da = a - a_prev;
      vec3 seg;
      for (int c = 0; c < 3; c++) {
        /* below 1e-3 the difference of exponentials cancels in float32: sinh(x) / x = 1 + x^2 / 6 */
        float dt = t - t_prev;
        seg[c] = abs(da[c]) < 1e-3 ? dt * exp(0.5 * (a[c] + a_prev[c])) * (1.0 + da[c] * da[c] / 24.0) :
                                     dt * (exp(a[c]) - exp(a_prev[c])) / da[c];
      }
      L += 0.5 * (f + f_prev) * seg;
    }
    a_prev = a;
    f_prev = f;
    t_prev = t;
  }
  return L;
}


void main()
{
  float here = eye_distance(frame.camera_position, frame.camera_forward, v_world);
  if (mode == 0) {
    out_color = vec4(0.0, 0.0, 0.0, here);
    return;
  }
  if (mode == 2) {
    float front = texelFetch(depths, ivec2(gl_FragCoord.xy), 0).a;
    if (here <= front * (1.0 + 1e-5) + 1e-6) {
      discard;
    }
    out_color = vec4(here);
    return;
  }
  vec3 n = normalize(v_normal);
  if (!gl_FrontFacing) {
    n = -n;
  }
  /* The surface gradient of the light's cosine from the pixel's derivatives (in uniform control flow):
   * grad f = (f_x (P_y x m) + f_y (m x P_x)) / |m|^2, m = P_x x P_y, exact for f linear on the plane. */
  vec3 to_light;
  vec3 E = emitter_irradiance(v_world, to_light);
  float mu_here = dot(n, to_light);
  vec3 P_x = dFdx(v_world), P_y = dFdy(v_world);
  vec3 m = cross(P_x, P_y);
  float mm = dot(m, m);
  vec3 grad_mu = mm > 0.0 ? (dFdx(mu_here) * cross(P_y, m) + dFdy(mu_here) * cross(m, P_x)) / mm : vec3(0.0);
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, v_world);
  /* Along outlines the smooth normal of a face that is seen can turn from the eye: bend it back to
   * graze at 0.05 rather than dropping the pixel, which left every other rim pixel dark. */
  float mu_o = dot(n, to_eye);
  if (mu_o < 0.05) {
    n = normalize(n + (0.05 - mu_o) * to_eye);
    mu_o = dot(n, to_eye);
  }
  vec3 w_t = refract(-to_eye, n, 1.0 / eta); /* eta >= 1 (the property's minimum): always refracts */
  float F_0 = fresnel_dielectric(1.0, eta);
  vec3 sigma_t = sigma_a.rgb + sigma_s.rgb;
  /* The exit target gives the chord along the eye's ray; along the refracted ray the medium ends at
   * chord mu_o / mu_t (exact between parallel faces; the same at eta = 1). */
  float mu_t = max(-dot(n, w_t), 1e-3);
  float t_exit = (texelFetch(depths, ivec2(gl_FragCoord.xy), 0).r - here) * mu_o / mu_t;
  float t_max = min(tau_max / min(sigma_t.r, min(sigma_t.g, sigma_t.b)), max(t_exit, 0.0));
  vec3 L = vec3(0.0);
  if ((terms & 1) != 0) {
    L += (1.0 - F_0) * march(v_world, w_t, t_max, sigma_t);
  }
  if ((terms & 2) != 0) {
    L += local_multiple(v_world, n, mu_t, E, to_light, grad_mu);
  }
  out_color = vec4((1.0 - fresnel_dielectric(mu_o, eta)) * L, 0.0);
}
#endif
