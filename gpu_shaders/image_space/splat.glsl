/* IMAGE_SPACE pass 3 (Shah 6.4.1): one camera-facing quad per light-view sample x_i, radius
 * r_max / M_d, accumulating R_d(M_d r) M_d^2 w(r) Phi into the scatter texture at every x_o of
 * the same object (id clipping, Shah 6.4.3). Light-view and world (depth-peeled) samples alike. The quad is moved toward the camera by its radius
 * so that its projection covers the whole sphere of influence.
 * Light samples hand the profile over to their tail from tail_start r_max to r_max (weights 1 - t and t,
 * physics/lut.py crossover): with tail_pass set, one quad per tail_block x tail_block block of samples (those
 * of the block's first object: summed power at the power-weighted mean position and blur) carries
 * R_d t out to tail_reach r_max from the tail rows of far_lut (image_space/model.py tail_samples is its twin).
 * Pairs across a thin part take the thin-part factor and leave by the diffusion mode's law (common/angular_law.glsl);
 * every pair leans away from x_i as it leaves (physics/exit_lean.py). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  int i = gl_InstanceID;
  vec4 pid;
  if (tail_pass == 1) {
    ivec2 size = textureSize(sample_pos_id, 0);
    int per_row = (size.x + tail_block - 1) / tail_block;
    ivec2 origin = ivec2(i % per_row, i / per_row) * tail_block;
    float slot = 0.0;
    vec3 position = vec3(0.0);
    vec4 flux = vec4(0.0);
    float weight = 0.0;
    for (int y = 0; y < tail_block; y++) {
      for (int x = 0; x < tail_block; x++) {
        ivec2 t = origin + ivec2(x, y);
        if (t.x >= size.x || t.y >= size.y) {
          continue;
        }
        vec4 p = texelFetch(sample_pos_id, t, 0);
        vec4 f = texelFetch(sample_flux, t, 0);
        if (p.w < 0.5 || max(f.r, max(f.g, f.b)) <= 0.0 || (slot > 0.5 && abs(p.w - slot) > 0.5)) {
          continue;
        }
        slot = p.w;
        float w = f.r + f.g + f.b;
        position += p.xyz * w;
        flux += vec4(f.rgb, f.a * w);
        weight += w;
      }
    }
    pid = vec4(position / max(weight, 1e-30), slot);
    v_flux = vec4(flux.rgb, flux.a / max(weight, 1e-30));
  }
  else {
    ivec2 t = ivec2(i % samples_per_row, i / samples_per_row);
    pid = texelFetch(sample_pos_id, t, 0);
    v_flux = texelFetch(sample_flux, t, 0);
  }
  v_xi = pid.xyz;
  v_slot = pid.w;
  if (pid.w < 0.5 || max(v_flux.r, max(v_flux.g, v_flux.b)) <= 0.0) {
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0); /* no sample: outside the clip volume */
    return;
  }
  vec4 mat = materials.params[2 * material_slot(pid.w)];
  float reach = (tail_pass == 1) ? tail_reach * mat.y : mat.y;
  float radius = reach / v_flux.a / mat.x; /* world units */
  vec4 c = frame.view * vec4(pid.xyz, 1.0);
  if (frame.camera_position.w < 0.5) {
    /* No nearer than just past the near plane (GL's projection: near = P[3][2] / (P[2][2] - 1)): a profile
     * reaching further than the camera's distance (a Principled material whose Subsurface Scale is near the
     * object's size, seen close up) moved its quad in front of it, where clipping took the whole splat. */
    float near = frame.proj[3][2] / (frame.proj[2][2] - 1.0);
    c.z = min(c.z + radius, -1.001 * near);
  }
  gl_Position = frame.proj * (c + vec4(corner * radius, 0.0, 0.0));
}
#endif

#ifdef GPU_FRAGMENT_SHADER
float one_minus_exp(float x)
{
  return (x < 1e-3) ? x * (1.0 - 0.5 * x) : 1.0 - exp(-x);
}

/* Light through thin parts (physics/slab_through.py): a slab's diffusion transmission over the half-space
 * dipole's at depth d below x_o's tangent plane, ramped in from 2 to 4 mean free paths (``ramp``, per channel). */
vec3 through_factor(int slot, float d, out vec3 ramp)
{
  vec4 c0 = materials.slab[2 * slot];
  vec3 z_r = materials.slab[2 * slot + 1].xyz;
  vec3 result;
  for (int k = 0; k < 3; k++) {
    float s = c0[k];
    float zr = z_r[k];
    if (d <= 2.0 * zr) {
      result[k] = 1.0;
      ramp[k] = 0.0; /* under 2 mean free paths (or a layer over a base): the half-space profile */
      continue;
    }
    float zb = 2.0 * c0.w * zr / 3.0;
    float zv = zr + 2.0 * zb;
    float cr = sqrt(d * d + zr * zr);
    float cv = sqrt(d * d + zv * zv);
    float T = 2.0 * exp(s * (zr - zb + cr - d)) * one_minus_exp(2.0 * s * (zr + zb)) /
              one_minus_exp(2.0 * s * (d + 2.0 * zb));
    float K = zr / cr + zv * exp(-s * (cv - cr)) / cv;
    ramp[k] = smoothstep(2.0 * zr, 4.0 * zr, d);
    result[k] = 1.0 + (T / K - 1.0) * ramp[k];
  }
  return result;
}

vec3 far_profile(int row, float u)
{
  int n = textureSize(far_lut, 0).x;
  float x = u * float(n - 1);
  int i0 = int(floor(x));
  int i1 = min(i0 + 1, n - 1);
  return mix(texelFetch(far_lut, ivec2(i0, row), 0).rgb, texelFetch(far_lut, ivec2(i1, row), 0).rgb,
             x - float(i0));
}

void main()
{
  vec4 xo = texelFetch(gbuffer, ivec2(gl_FragCoord.xy), 0);
  if (abs(xo.w - v_slot) > 0.5) {
    discard; /* another object, or the background */
  }
  int slot = material_slot(v_slot);
  vec4 mat = materials.params[2 * slot];
  float M = v_flux.a;
  float r_mm = length(xo.xyz - v_xi) * mat.x;
  float s = r_mm * M;
  float reach = (tail_pass == 1) ? tail_reach * mat.y : mat.y;
  if (s >= reach) {
    discard;
  }
  float t = smoothstep(tail_start * mat.y, mat.y, s); /* the tail's share */
  vec3 R;
  if (tail_pass == 1) {
    R = far_profile(slot + textureSize(far_lut, 0).y / 3, sqrt(s / reach)) * t;
  }
  else {
    R = far_profile(slot, sqrt(s / reach)) * ((world_pass == 1) ? 1.0 : 1.0 - t);
  }
  float rho = (world_pass == 1) ? materials.params[2 * slot + 1].w : mat.z; /* world samples: their rho */
  vec3 n_o = texelFetch(gbuffer_normal, ivec2(gl_FragCoord.xy), 0).xyz;
  float h_mm = dot(n_o, xo.xyz - v_xi) * mat.x; /* x_i below x_o's tangent plane: > 0 */
  float w = partition_weight_off_plane(r_mm, rho, abs(h_mm));
  /* Light that crossed a thin part leaves by the diffusion mode's law, not the angular law the composite
   * applies: over the same ramp as the thin-part factor. */
  vec3 ramp;
  vec3 C = through_factor(slot, max(h_mm, 0.0), ramp);
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, xo.xyz);
  if (max(ramp.r, max(ramp.g, ramp.b)) > 0.0) { /* most pairs lie on one face: nothing to weigh */
    C *= mix(vec3(1.0), through_exit_ratio(slot, dot(n_o, to_eye)), ramp);
  }
  /* The light leaving leans away from x_i (physics/exit_lean.py): max(0, 1 + beta(r) to_eye . e) / N(beta), e the
   * unit part of x_o - x_i along x_o's surface; beta from far_lut's lean rows (0 for DIPOLE and a layer over a
   * base), across a thin part too: there the light is still travelling from the lit face to the dark one
   * (scripts/cylinder_mc.py --angular: a 2.5 mm marble cylinder's dark side sends 1.41 / 0.69 towards the
   * dark / lit side at view cosine 0.5; leaning only outside the ramp drew 0.95 / 0.83, leaning here 1.06 / 0.72). */
  vec3 along = (xo.xyz - v_xi) - n_o * dot(n_o, xo.xyz - v_xi);
  float along_length = length(along);
  if (along_length > 0.0) {
    vec3 beta = far_profile(slot + 2 * (textureSize(far_lut, 0).y / 3), sqrt(min(r_mm / mat.y, 1.0)));
    vec3 x = clamp(beta, vec3(1.0), vec3(2.0)) - vec3(1.0); /* exit_lean.normalisation: the clamp's extra light */
    C *= max(vec3(1.0) + beta * dot(to_eye, along / along_length), vec3(0.0)) /
         (vec3(1.0) + x * x * (0.0985 - 0.0181 * x));
  }
  out_color = vec4(R * C * (M * M * w) * v_flux.rgb, 1.0);
}
#endif
