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
