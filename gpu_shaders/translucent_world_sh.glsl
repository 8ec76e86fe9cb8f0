/* Library of the passes with a `materials` block (MaterialsData) that light with the world. */
/* E(n) = sum A_l L_lm Y_lm(n): the world's irradiance transmitted into slot k's medium (Shah Eq.
 * 6.19-6.21 by Funk-Hecke; physics/sh_irradiance.py is the CPU twin). */
vec3 world_irradiance(vec3 n, int slot)
{
  vec3 A = materials.world_kernel[slot].xyz;
  const float C0 = 0.282094792, C1 = 0.488602512, C2 = 1.092548431, C20 = 0.315391565;
  vec3 E = A.x * C0 * materials.world_sh[0].rgb;
  E += A.y * C1 * (n.y * materials.world_sh[1].rgb + n.z * materials.world_sh[2].rgb + n.x * materials.world_sh[3].rgb);
  E += A.z * (C2 * n.x * n.y * materials.world_sh[4].rgb + C2 * n.y * n.z * materials.world_sh[5].rgb +
              C20 * (3.0 * n.z * n.z - 1.0) * materials.world_sh[6].rgb + C2 * n.x * n.z * materials.world_sh[7].rgb +
              0.5 * C2 * (n.x * n.x - n.y * n.y) * materials.world_sh[8].rgb);
  return max(E, vec3(0.0));
}
