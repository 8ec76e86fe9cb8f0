/* QUADGRAPH relaxation, one Jacobi step for every node of a level (Wang Eq. 8-9, Fig. 8), the GPU
 * twin of physics/diffusion.py relax(). Inner node i: phi_i = sum_j c_ij phi_j / (sum_j c_ij + mu_i)
 * with c_ij = a_ij kappa_ij (harmonic mean); surface node s with inner node k at distance d:
 * phi_s = (2 A kappa_s e1 phi_k + d 4 q / (1 - F_dr)) / (2 A kappa_s e2 + d), where e1 = x / sinh x,
 * e2 = x / tanh x, x = sigma_tr d (the fitted surface link; a link to a surface node carries e1 on
 * phi_s and e2 on phi_i). q is the light entering at the node times its painted factor (mask x glow x tint). */
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
    else {
      float ex = exp(-t);
      float sh = 0.5 * (1.0 / ex - ex);
      e1[c] = t / sh;
      e2[c] = t * (0.5 * (1.0 / ex + ex)) / sh;
    }
  }
}

void surface_factors(int slot, float d, out vec3 e1, out vec3 e2)
{
  ivec2 p = qg_texel(slot, blocks_per_row);
  vec3 kappa = texelFetch(node_kappa, p, 0).rgb;
  vec3 mu = texelFetch(node_mu, p, 0).rgb;
  link_factors(sqrt(mu / kappa) * d, e1, e2);
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
    vec3 e1, e2;
    surface_factors(slot, d, e1, e2);
    vec3 phi_k = texelFetch(phi, qg_texel(k, blocks_per_row), 0).rgb;
    vec3 q = texelFetch(incident, p, 0).rgb * texelFetch(q_factor, p, 0).rgb; /* painted mask, glow, tint */
    vec3 ks = 2.0 * A * kappa;
    out_phi = vec4((ks * e1 * phi_k + d * 4.0 * q / (1.0 - F_dr)) / (ks * e2 + d), 1.0);
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
      vec3 e1, e2;
      surface_factors(n, texelFetch(weights_map, q, 0).x, e1, e2);
      num += c * e1 * phi_j;
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
