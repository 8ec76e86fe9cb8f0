/* Light entering at an angle starts its diffusion one mean free path along the refracted beam
 * (physics/oblique_entry.py). What replaces cos_i in the irradiance entering at a point, per channel: the
 * cosine at the upstream point p - ell v (v = -(l - (l . n) n) / eta, the refracted beam's part in the tangent
 * plane) times the Jacobian of the shift, 1 - ell cos_i div n / eta, over a normal turning at most TURN_MAX
 * within ell; 0 where the point is not lit itself (cos_i <= 0). ell: per channel, in world units (0: no shift).
 * S: the surface's shape operator in world space (dN = S dP), the corners' (oblique_entry.corner_shape_operators)
 * interpolated: ``shape_operator`` of the two vectors the vertex stage passes on. */
vec3 oblique_cosine(vec3 n, vec3 to_light, float eta, vec3 ell, mat3 S)
{
  float cos_i = dot(n, to_light);
  if (cos_i <= 0.0) {
    return vec3(0.0);
  }
  if (max(ell.r, max(ell.g, ell.b)) <= 0.0) {
    return vec3(cos_i);
  }
  vec3 v = -(to_light - cos_i * n) / eta;
  vec3 dn_v = S * v;
  float div_n = S[0][0] + S[1][1] + S[2][2];
  const float TURN_MAX = 0.15; /* oblique_entry.TURN_MAX: the normal turns by at most this over ell */
  float dn = length(dn_v);
  vec3 result;
  for (int c = 0; c < 3; c++) {
    vec3 n_up = normalize(n - min(ell[c], TURN_MAX / max(dn, 1e-30)) * dn_v);
    float J = 1.0 - clamp(ell[c] * div_n, -2.0 * TURN_MAX, 2.0 * TURN_MAX) * cos_i / eta;
    result[c] = max(dot(n_up, to_light), 0.0) * J;
  }
  return result;
}

/* The symmetric S from its diagonal and its (xy, xz, yz) entries. */
mat3 shape_operator(vec3 diagonal, vec3 off)
{
  return mat3(diagonal.x, off.x, off.y, off.x, diagonal.y, off.z, off.y, off.z, diagonal.z);
}

/* An object-space S in world space (``normal_world`` is N n): dP_w = M dP, M^-1 = N^T (N the normal matrix),
 * and the unit normal n_w = N n / |N n| changes by P N dN / |N n| to first order, P = I - n_w n_w^T (N dN
 * leaves the world tangent plane where the scale is not uniform), so S_w = P N S N^T P / |N n| (symmetric;
 * the P on the right drops the normal's component of a displacement, which S ignores). */
mat3 world_shape_operator(mat3 normal_matrix, vec3 normal_world, vec3 diagonal, vec3 off)
{
  float length_n = max(length(normal_world), 1e-30);
  vec3 n = normal_world / length_n;
  mat3 P = mat3(1.0) - outerProduct(n, n);
  return P * normal_matrix * shape_operator(diagonal, off) * transpose(normal_matrix) * P / length_n;
}
