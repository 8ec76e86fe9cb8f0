/* Library of the passes with a `frame` block that light with the world's spherical harmonics. */
/* E(n) = sum A_l L_lm Y_lm(n): the world's irradiance transmitted through a boundary whose kernel
 * F_t (n . w) has Funk-Hecke coefficients A (Shah Eq. 6.19-6.21; physics/sh_irradiance.py is the
 * CPU twin). */
const vec3 LAMBERT_KERNEL = vec3(3.14159265, 2.09439510, 0.78539816); /* A_l without a boundary: pi, 2pi/3, pi/4 */

vec3 world_irradiance(vec3 n, vec3 A)
{
  const float C0 = 0.282094792, C1 = 0.488602512, C2 = 1.092548431, C20 = 0.315391565;
  vec3 E = A.x * C0 * frame.world_sh[0].rgb;
  E += A.y * C1 * (n.y * frame.world_sh[1].rgb + n.z * frame.world_sh[2].rgb + n.x * frame.world_sh[3].rgb);
  E += A.z * (C2 * n.x * n.y * frame.world_sh[4].rgb + C2 * n.y * n.z * frame.world_sh[5].rgb +
              C20 * (3.0 * n.z * n.z - 1.0) * frame.world_sh[6].rgb + C2 * n.x * n.z * frame.world_sh[7].rgb +
              0.5 * C2 * (n.x * n.x - n.y * n.y) * frame.world_sh[8].rgb);
  return max(E, vec3(0.0));
}
