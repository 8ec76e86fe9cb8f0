/* QUADGRAPH relaxation, one Jacobi step for every node of a level (Wang Eq. 8-9, Fig. 8), the GPU
 * twin of physics/diffusion.py relax(). Inner node i:
 * phi_i = (sum_j c_ij phi_j + sum_{j surface} a_ij d_j w_k,j q_j) / (sum_j c_ij + mu_i)
 * with c_ij = a_ij kappa_ij (harmonic mean); surface node s with inner node k at distance d:
 * phi_s = (2 A kappa_s e1 phi_k + 2 A d w_s q) / (2 A kappa_s e2 + d), where e1 = x / sinh x,
 * e2 = x / tanh x, x = sigma_tr d (the fitted surface link; a link to a surface node carries e1 on
 * phi_s and e2 on phi_i). q is the light entering at the node times its painted factor (mask x glow x
 * tint), a source one transport mean free path deep in the link (z_0 = 3 kappa_s): w_s and w_k of
 * physics/diffusion.py source_split go to the surface node's row and, as a_ks d w_k q, to the inner
 * node's (Eq. 8 with a source). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  gl_Position = vec4(corner, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void link_factors(vec3 x, out vec3 e1, out vec3 e2)
{
  for (int c = 0; c < 3; c++) {
    float t = min(x[c], 80.0);
    if (t < 1e-3) {
      e1[c] = 1.0 - t * t / 6.0;
      e2[c] = 1.0 + t * t / 3.0;
    }
    else { /* x / sinh x and x coth x, the hyperbolics held at t = min(x, 80) (coth is 1 there) */
      float ex = exp(-t);
      float sh = 0.5 * (1.0 / ex - ex);
      e1[c] = x[c] / sh;
      e2[c] = x[c] * (0.5 * (1.0 / ex + ex)) / sh;
    }
  }
}

/* sinh(sigma a) / sinh(sigma b) for lengths 0 <= a <= b (diffusion._sinh_ratio); where sigma b < 1e-2 its
 * series (a / b)(1 + sigma^2 (a^2 - b^2) / 6), where 1 - exp(-2 sigma b) cancels in float32, and which keeps
 * a / b for a medium that absorbs nothing (sigma = 0). */
float sinh_ratio(float sigma, float a, float b)
{
  float x = sigma * a;
  float y = sigma * b;
  if (y < 1e-2) {
    return a / max(b, 1e-30) * (1.0 + (x * x - y * y) / 6.0);
  }
  return exp(x - y) * (1.0 - exp(-2.0 * x)) / (1.0 - exp(-2.0 * y));
}

/* The fitted link factors of a surface node's link and the shares (w_s, w_k) of its source. */
void surface_factors(int slot, float d, out vec3 e1, out vec3 e2, out vec3 w_s, out vec3 w_k)
{
  ivec2 p = qg_texel(slot, blocks_per_row);
  vec3 kappa = texelFetch(node_kappa, p, 0).rgb;
  vec3 mu = texelFetch(node_mu, p, 0).rgb;
  vec3 sigma_tr = sqrt(mu / kappa);
  link_factors(sigma_tr * d, e1, e2);
  vec3 z0 = min(3.0 * kappa, vec3(d)); /* at the inner node where the link is shorter */
  for (int c = 0; c < 3; c++) {
    w_s[c] = sinh_ratio(sigma_tr[c], d - z0[c], d);
    w_k[c] = sinh_ratio(sigma_tr[c], z0[c], d);
  }
}

vec3 entering(ivec2 p)
{
  return texelFetch(incident, p, 0).rgb * texelFetch(q_factor, p, 0).rgb; /* painted mask, glow, tint */
}

void main()
{
  ivec2 p = ivec2(gl_FragCoord.xy);
  int slot = qg_slot(p, blocks_per_row);
  bool surface = slot < n_surface;
  if (!surface && (slot < inner_start || slot >= inner_end)) {
    out_phi = vec4(0.0);
    return;
  }
  vec4 links = texelFetch(links_map, p, 0);
  vec4 w = texelFetch(weights_map, p, 0);
  vec3 kappa = texelFetch(node_kappa, p, 0).rgb;
  if (surface) {
    int k = int(links.x + 0.5);
    float d = w.x;
    vec3 e1, e2, w_s, w_k;
    surface_factors(slot, d, e1, e2, w_s, w_k);
    vec3 phi_k = texelFetch(phi, qg_texel(k, blocks_per_row), 0).rgb;
    vec3 ks = 2.0 * A * kappa;
    out_phi = vec4((ks * e1 * phi_k + 2.0 * A * d * w_s * entering(p)) / (ks * e2 + d), 1.0);
    return;
  }
  vec3 num = vec3(0.0);
  vec3 den = texelFetch(node_mu, p, 0).rgb;
  for (int j = 0; j < 4; j++) {
    int n = int(links[j] + 0.5);
    ivec2 q = qg_texel(n, blocks_per_row);
    vec3 kj = texelFetch(node_kappa, q, 0).rgb;
    vec3 c = w[j] * 2.0 * kappa * kj / (kappa + kj);
    vec3 phi_j = texelFetch(phi, q, 0).rgb;
    if (n < n_surface) {
      vec3 e1, e2, w_s, w_k;
      float d = texelFetch(weights_map, q, 0).x;
      surface_factors(n, d, e1, e2, w_s, w_k);
      num += c * e1 * phi_j + w[j] * d * w_k * entering(q);
      den += c * e2;
    }
    else {
      num += c * phi_j;
      den += c;
    }
  }
  out_phi = vec4(num / den, 1.0);
}
#endif
