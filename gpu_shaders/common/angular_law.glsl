/* The angular law of subsurface light (physics/angular_law.py): the power entering at cosine mu_i is
 * weighed by a(mu_i) and the light leaving towards mu_o by a(mu_o). A slot's 16 values in the materials
 * block at mu = (j + 0.5) / 16, read linearly between them and clamped at the ends (angular_law.lookup). */
vec3 angular_weight(int slot, float mu)
{
  float u = clamp(mu * 16.0 - 0.5, 0.0, 15.0);
  int j = min(int(floor(u)), 15);
  return mix(materials.angular[16 * slot + j].rgb, materials.angular[16 * slot + min(j + 1, 15)].rgb,
             u - float(j));
}

/* Hapke's closed form of Chandrasekhar's H for gamma = sqrt(1 - alpha') (angular_law.H_approx). */
float H_approx(float gamma, float x)
{
  x = max(x, 1e-6);
  float r0 = (1.0 - gamma) / (1.0 + gamma);
  return 1.0 / (1.0 - (1.0 - gamma) * x * (r0 + (1.0 - 0.5 * r0 - r0 * x) * log((1.0 + x) / x)));
}

/* How the light that crossed a thin part leaves towards cosine mu over the angular law a(mu): M(mu) / a(mu),
 * M(mu) = H(mu_t) / (1 - k mu_t) / <M> the slowest diffusion mode's emergent law (angular_law.through_exit);
 * 1 where the slot keeps the Lambertian law. */
vec3 through_exit_ratio(int slot, float mu)
{
  vec4 g = materials.through_exit[3 * slot];
  if (g.w < 0.5) {
    return vec3(1.0);
  }
  vec3 k = materials.through_exit[3 * slot + 1].xyz;
  vec3 inv_mean = materials.through_exit[3 * slot + 2].xyz;
  float eta = materials.params[2 * slot].w;
  mu = clamp(mu, 0.0, 1.0);
  float mu_t = sqrt(max(1.0 - (1.0 - mu * mu) / (eta * eta), 0.0));
  vec3 M;
  for (int c = 0; c < 3; c++) {
    M[c] = H_approx(g[c], mu_t) / (1.0 - k[c] * mu_t) * inv_mean[c];
  }
  return M / angular_weight(slot, mu);
}
