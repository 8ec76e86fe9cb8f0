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
 *   lateral average of the clamped ramp the curved surface sees (physics/terminator.py), its face the
 *   flat triangle where that is wider than the kernel (terminator.facet_weight), times the geometry
 *   factor of the eye's chord (single_scattering.chord_factor): the same march's reach of the diffuse
 *   light, exp(-sigma_t t - sigma_tr d), over a flat face's.
 * Both leave through T_o = 1 - F_r(mu_o). sigma_a, sigma_s: rgb per world unit, in vec4s.
 * ``out_spread`` (second attachment, summed over the emitters like the colour): what the graph's diffusion
 * draws of the light the term's mu_eff spreads past where it entered, R T_i E (mu_eff - max(mu_i, 0)) with
 * ``R_loss`` = single_scattering.exitance_loss; qg_display takes it from B, which holds it where the
 * graph's lateral links resolve the kernel (drawn twice before). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  v_corner = corner;
  gl_Position = frame.view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
/* Path length in the medium from the first surface the emitter's light meets to p: the distance
 * atlas (pipeline/shadow_distance.glsl) holds that surface's distance, interpolated bilinearly over those of
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

/* beta(s) per channel: the lateral kernel's share beyond a line s rho away (s >= 0), -dG/ds by a
 * forward difference on the table (terminator.beyond_line; 1 / 2 at the line). */
vec3 beyond_line(vec3 s)
{
  const float h = 0.02;
  vec3 beta;
  for (int c = 0; c < 3; c++) {
    float u0 = 0.5 + 0.5 * s[c] / (s[c] + 1.0), u1 = 0.5 + 0.5 * (s[c] + h) / (s[c] + h + 1.0);
    beta[c] = (table_lerp(terminator_table, u0)[c] - table_lerp(terminator_table, u1)[c]) / h;
  }
  return clamp(beta, vec3(0.0), vec3(0.5));
}

/* The triangle's own normal's share t per channel in the medium's normal at the kernel's scale
 * (terminator.facet_weight): the kernel's share inside the triangle, w = prod_i (1 - beta(d_i / rho)),
 * as t = max(2 w - 1, 0), 0 at the edges (1 / 2 of the kernel inside), where the normal must not jump. */
vec3 facet_weight(vec3 edge_distance)
{
  vec3 inside = vec3(1.0);
  for (int i = 0; i < 3; i++) {
    inside *= vec3(1.0) - beyond_line(vec3(edge_distance[i]) / max(terminator_rho.rgb, vec3(1e-30)));
  }
  return max(2.0 * inside - 1.0, vec3(0.0));
}

/* The local multiple scattering L^(ms) of light entering at this pixel's surface point:
 * Chandrasekhar's half-space (single_scattering.multiple_half_space), at the refracted cosines between
 * the Fresnel transmittances, for the light entering per unit area T_i E mu_i (mu_i outside, as q); the
 * light's visibility as q's (ts_illumination); E and to_light: the emitter's at p. Per channel c the
 * face is the medium's at that channel's kernel scale (n_k[c], facet_weight): mu_i[c] = n_k[c] . to_light,
 * mu_o[c] its cosine to the eye, grad_mu[c] the surface gradient of mu_i[c].
 * On a curved surface mu_i is the effective cosine of physics/terminator.py per channel, mu_eff = max(mu_i, 0) + g rho G(mu_i / (g rho)), g = |grad_mu|
 * the surface gradient of the light's cosine: the lateral spread of the light entering beside the
 * terminator, which also lights the pixels just past it. There the light entered at about mu_eff
 * (H and T_i take the larger of the two) and its visibility is the terminator's, min(-mu_i / g, 8 rho)
 * along the gradient, tested along the light. Measured against the alternatives: one kernel radius
 * further into the lit side removes the black wedges a faceted ball's terminator leaves in this term
 * alone (its facets shadow the smooth terminator; the diffusion covers them in the image) but leaks
 * light into cast shadows (3 pixels inside the outline, the cow's RMSE 0.118 -> 0.142 where this
 * rule gave 0.132 -> 0.134, on other bakes); the pixel's own point tested along the light draws jagged
 * streaks. */
vec3 local_multiple(vec3 p, vec3 n_shade, vec3 mu_i, vec3 mu_o, vec3 E, vec3 to_light, mat3 grad_mu, vec3 chord,
                    vec3 sigma_t, vec3 sigma_tr, float t_flat, out vec3 spread)
{
  spread = vec3(0.0);
  vec3 sigma_s_prime = sigma_s.rgb * (1.0 - g);
  vec3 alpha_prime = sigma_s_prime / (sigma_a.rgb + sigma_s_prime);
  float rho = max(terminator_rho.r, max(terminator_rho.g, terminator_rho.b));
  float vis_here = -1.0, vis_beyond = -1.0;
  vec3 L = vec3(0.0);
  for (int c = 0; c < 3; c++) {
    float slope = length(grad_mu[c]);
    /* The ramp holds while the kernel spans less than the curvature's radius: g rho at most 1 (mu_eff at
     * most 1 / pi at the terminator; a ball much smaller than rho averages max(0, cos) to 1 / 4), not
     * g rho / pi without bound on a low-poly mesh's sharp bends (the cow's normals turn by 0.14 / mm in
     * the median triangle, 1.2 / mm in one of a hundred). */
    float scale = min(slope * terminator_rho[c], 1.0); /* terminator.SCALE_MAX */
    float u = 0.5 + 0.5 * mu_i[c] / (abs(mu_i[c]) + scale + 1e-30);
    float mu_eff = max(mu_i[c], 0.0) + scale * table_lerp(terminator_table, u)[c];
    if (mu_eff <= 0.0) {
      continue;
    }
    float vis;
    if (mu_i[c] > 0.0) {
      vis = vis_here < 0.0 ? (vis_here = visibility(p, n_shade)) : vis_here;
    }
    else {
      /* the terminator of the channels' mean cosine, tested once */
      vec3 grad = (grad_mu[0] + grad_mu[1] + grad_mu[2]) / 3.0;
      float mean = (mu_i.r + mu_i.g + mu_i.b) / 3.0, g_mean = max(length(grad), 1e-30);
      vis = vis_beyond < 0.0 ?
                (vis_beyond = visibility(p + grad / g_mean * clamp(-mean / g_mean, 0.0, 8.0 * rho), to_light)) :
                vis_beyond;
    }
    float mu_h = max(mu_i[c], mu_eff);
    float mu_it = sqrt(1.0 - (1.0 - mu_h * mu_h) / (eta * eta));
    float T_i = 1.0 - fresnel_dielectric(mu_h, eta);
    float mu_ot = sqrt(1.0 - (1.0 - mu_o[c] * mu_o[c]) / (eta * eta));
    /* The geometry factor (single_scattering.chord_factor): the eye's chord's diffuse reach (march)
     * over a flat face's, where the light's straight path is d = t mu_ot / mu_h (flat_reach), at most 4
     * (CHORD_FACTOR_MAX). */
    float k_flat = sigma_t[c] + sigma_tr[c] * mu_ot / mu_h;
    float flat_reach = (1.0 - exp(-k_flat * t_flat)) / k_flat;
    float geometry = clamp(chord[c] / flat_reach, 0.0, 4.0);
    L[c] = geometry * vis * T_i * E[c] * alpha_prime[c] * mu_eff * (chandrasekhar_H(mu_it)[c] * chandrasekhar_H(mu_ot)[c] - 1.0) /
           (4.0 * PI * (mu_it + mu_ot));
    /* What the graph draws of the same spread where it resolves it: its exitance R q for the light that
     * entered beside this point (``spread``, taken from B by qg_display). */
    spread[c] = R_loss[c] * vis * T_i * E[c] * (mu_eff - max(mu_i[c], 0.0));
  }
  return L;
}

float hg_phase(float cos_theta)
{
  float g2 = g * g;
  return (1.0 - g2) / (4.0 * PI * pow(max(1.0 + g2 - 2.0 * g * cos_theta, 1e-6), 1.5));
}

/* integral over [0, t] of exp(a) for a linear in t from a_0 to a_1: exact (sinh(x) / x below 1e-3,
 * where the difference of exponentials cancels in float32). */
vec3 linear_exp(float dt, vec3 a_0, vec3 a_1)
{
  vec3 seg;
  for (int c = 0; c < 3; c++) {
    float da = a_1[c] - a_0[c];
    seg[c] = abs(da) < 1e-3 ? dt * exp(0.5 * (a_1[c] + a_0[c])) * (1.0 + da * da / 24.0) :
                              dt * (exp(a_1[c]) - exp(a_0[c])) / da;
  }
  return seg;
}

/* integral over [0, t_max] of sigma_s p E exp(-sigma_t (t + d)) along x_o + t w_t: per segment, the
 * source's mean at the ends times the exponential of the linear exponent, integrated exactly.
 * ``chord``: the same march of exp(-sigma_t t - sigma_tr d), the diffuse light's reach along the ray
 * (local_multiple's geometry factor). */
vec3 march(vec3 x_o, vec3 w_t, float t_max, vec3 sigma_t, vec3 sigma_tr, out vec3 chord)
{
  vec3 L = vec3(0.0);
  chord = vec3(0.0);
  vec3 a_prev = vec3(0.0), b_prev = vec3(0.0), f_prev = vec3(0.0);
  float t_prev = 0.0;
  for (int k = 0; k <= segments; k++) {
    float s = float(k) / float(segments);
    float t = t_max * s * s;
    vec3 x = x_o + t * w_t;
    vec3 to_light;
    vec3 E = emitter_irradiance(x, to_light);
    float d = light_path(x);
    vec3 a = -sigma_t * (t + d);
    vec3 b = -sigma_t * t - sigma_tr * d;
    vec3 f = sigma_s.rgb * hg_phase(dot(to_light, w_t)) * E;
    if (k > 0) {
      L += 0.5 * (f + f_prev) * linear_exp(t - t_prev, a_prev, a);
      chord += linear_exp(t - t_prev, b_prev, b);
    }
    a_prev = a;
    b_prev = b;
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
    out_spread = vec4(0.0);
    return;
  }
  if (mode == 2) {
    float front = texelFetch(depths, ivec2(gl_FragCoord.xy), 0).a;
    if (here <= front * (1.0 + 1e-5) + 1e-6) {
      discard;
    }
    out_color = vec4(here);
    out_spread = vec4(0.0);
    return;
  }
  vec3 n = normalize(v_normal);
  if (!facing_out(object.shading)) {
    n = -n;
  }
  /* Surface gradients from the pixel's derivatives (in uniform control flow):
   * grad f = (f_x (P_y x m) + f_y (m x P_x)) / |m|^2, m = P_x x P_y, exact for f linear on the plane. */
  vec3 to_light;
  vec3 E = emitter_irradiance(v_world, to_light);
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, v_world);
  vec3 P_x = dFdx(v_world), P_y = dFdy(v_world);
  vec3 m = cross(P_x, P_y);
  float mm = dot(m, m);
  vec3 gx = mm > 0.0 ? cross(P_y, m) / mm : vec3(0.0), gy = mm > 0.0 ? cross(m, P_x) / mm : vec3(0.0);
  /* The medium is bounded by the flat triangle (its normal faces the eye: the fragment is seen); per
   * channel it takes the triangle's share of its kernel (facet_weight, from the distances to the
   * triangle's edges, d_i = b_i / |grad b_i|). */
  vec3 n_facet = mm > 0.0 ? normalize(m) : n;
  n_facet = dot(n_facet, to_eye) < 0.0 ? -n_facet : n_facet;
  vec3 b_x = dFdx(v_corner), b_y = dFdy(v_corner), edge_distance;
  for (int i = 0; i < 3; i++) {
    edge_distance[i] = max(v_corner[i], 0.0) / max(length(b_x[i] * gx + b_y[i] * gy), 1e-30);
  }
  vec3 t = facet_weight(edge_distance);
  mat3 n_k;
  vec3 mu_k, mu_ko;
  for (int c = 0; c < 3; c++) {
    n_k[c] = normalize(mix(n, n_facet, t[c]));
    mu_k[c] = dot(n_k[c], to_light);
  }
  vec3 mu_x = dFdx(mu_k), mu_y = dFdy(mu_k);
  mat3 grad_mu = mat3(mu_x.r * gx + mu_y.r * gy, mu_x.g * gx + mu_y.g * gy, mu_x.b * gx + mu_y.b * gy);
  /* Along outlines the smooth normal of a face that is seen can turn from the eye: bend it back to
   * graze at 0.05 rather than dropping the pixel, which left every other rim pixel dark. */
  for (int c = 0; c < 3; c++) {
    mu_ko[c] = max(dot(n_k[c], to_eye), 0.05);
  }
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
  vec3 sigma_s_prime = sigma_s.rgb * (1.0 - g);
  vec3 sigma_tr = sqrt(3.0 * sigma_a.rgb * (sigma_a.rgb + sigma_s_prime));
  vec3 chord;
  vec3 L_1 = march(v_world, w_t, t_max, sigma_t, sigma_tr, chord);
  if ((terms & 1) != 0) {
    L += (1.0 - F_0) * L_1;
  }
  vec3 spread = vec3(0.0);
  if ((terms & 2) != 0) {
    /* the first escape, and what the boundary reflects back in to leave later (boundary_gain.py) */
    L += boundary_gain.rgb * local_multiple(v_world, n, mu_k, mu_ko, E, to_light, grad_mu, chord, sigma_t,
                                            sigma_tr, tau_max / min(sigma_t.r, min(sigma_t.g, sigma_t.b)), spread);
  }
  out_spread = vec4(spread, 0.0);
  /* out of the medium: Fresnel's transmittance and the radiance's n^2 law (single_scattering.py) */
  out_color = vec4((1.0 - fresnel_dielectric(mu_o, eta)) / (eta * eta) * L, 0.0);
}
#endif
