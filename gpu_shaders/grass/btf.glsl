/* Grass field pass (Shah 4.3.3): the ground mesh drawn as the top of a grass layer (its vertices
 * moved out along the normal by the blades' height), the BTF reconstructed per pixel (Eq. 4.4) from
 * eigen-textures and coefficients, interpolating the three nearest sampled views and lights;
 * silhouettes by discarding where the depth maps say the ray meets no blade; external occlusion by
 * writing the depth of the blade the ray hits. Mode 0: the uniform world (the BTF integrated over
 * lights); mode 1: one emitter, with shadows from the scene at the blade. NumPy twin:
 * translucent_addon/techniques/grass/model.py (shade). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec3 n_w = normalize(mat3(object.normal_matrix) * nor);
  vec4 world = object.model * vec4(pos, 1.0);
  float tile = grass.scale.x;
  vec3 shell = world.xyz + n_w * grass.scale.y * tile;
  v_world = shell;
  v_normal = n_w;
  vec3 sx = object.model[0].xyz;
  vec3 sy = object.model[1].xyz;
  v_uv = vec2(pos.x * length(sx), pos.y * length(sy)) / tile;
  v_tangent = normalize(sx);
  gl_Position = frame.view_proj * vec4(shell, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
/* hemisphere.disk_coordinates: theta / (pi / 2) (cos phi, sin phi), below the horizon at it. */
vec2 disk(vec3 d)
{
  d.z = max(d.z, 0.0);
  d = normalize(d);
  float r = acos(clamp(d.z, -1.0, 1.0)) / (0.5 * PI);
  float rho = length(d.xy);
  return (rho > 1e-12) ? d.xy / rho * r : vec2(r, 0.0);
}

/* The three nearest sampled directions and their weights (table 0: views, 1: lights). */
void nearest3(vec3 d, int table, out ivec3 idx, out vec3 w)
{
  int T = int(grass.scale.w + 0.5);
  ivec2 cell = clamp(ivec2(floor((disk(d) + 1.0) * 0.5 * float(T))), ivec2(0), ivec2(T - 1));
  idx = ivec3(texelFetch(btf_tables, ivec2(cell.x + 2 * table * T, cell.y), 0).rgb + 0.5);
  w = texelFetch(btf_tables, ivec2(cell.x + (2 * table + 1) * T, cell.y), 0).rgb;
}

ivec2 wrap_texel(ivec2 t, int R)
{
  t = t % R;
  return t + R * ivec2(lessThan(t, ivec2(0)));
}

void main()
{
  int R = int(grass.scale.z + 0.5);
  int n_v = int(grass.counts.x + 0.5);
  int n_l1 = int(grass.counts.y + 0.5) + 1; /* lights plus the sky column */
  ivec3 g = ivec3(grass.groups.xyz + 0.5);
  /* Fewer luminance eigen-textures with distance (Shah 4.5): all of them while a BTF texel covers a
   * pixel or more, then in proportion to the texels per pixel, down to groups.w. */
  float texels_per_pixel = float(R) * max(length(dFdx(v_uv)), length(dFdy(v_uv)));
  int g_y = g.x;
  if (grass.counts.w > 0.0 && texels_per_pixel > grass.counts.w) {
    g_y = clamp(int(ceil(float(g.x) * grass.counts.w / texels_per_pixel)), int(grass.groups.w + 0.5), g.x);
  }

  vec3 N = normalize(v_normal);
  /* Screen derivatives before any discard (defined only in uniform control flow). */
  vec3 dP_dx = dFdx(v_world), dP_dy = dFdy(v_world), dN_dx = dFdx(N), dN_dy = dFdy(N);
  vec3 Tg = normalize(v_tangent - N * dot(v_tangent, N));
  vec3 Bg = cross(N, Tg);
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, v_world);
  vec3 wv = vec3(dot(to_eye, Tg), dot(to_eye, Bg), dot(to_eye, N));
  if (wv.z <= 0.0) {
    discard; /* the layer seen from below */
  }
  ivec3 vi;
  vec3 vw;
  nearest3(wv, 0, vi, vw);

  /* Wrapped bilinear taps: the tile's neighbours blend across its edges. */
  vec2 t = v_uv * float(R) - 0.5;
  vec2 f = fract(t);
  ivec2 i0 = ivec2(floor(t));
  ivec2 tap[4];
  float bw[4];
  for (int k = 0; k < 4; k++) {
    ivec2 o = ivec2(k & 1, k >> 1);
    tap[k] = wrap_texel(i0 + o, R);
    bw[k] = ((o.x == 1) ? f.x : 1.0 - f.x) * ((o.y == 1) ? f.y : 1.0 - f.y);
  }
  /* Hit weights per view and tap (0 where the depth map holds the -1 sentinel), coverage, depth. */
  float hw[12];
  float coverage = 0.0;
  float depth_sum = 0.0;
  for (int j = 0; j < 3; j++) {
    ivec2 origin = ivec2(vi[j] % 9, vi[j] / 9) * R;
    for (int k = 0; k < 4; k++) {
      float d = texelFetch(btf_depth, origin + tap[k], 0).r;
      float w = (d > -0.5) ? bw[k] : 0.0;
      hw[4 * j + k] = w;
      coverage += vw[j] * w;
      depth_sum += vw[j] * w * d;
    }
  }
  if (coverage < 0.5) {
    discard; /* a gap between blades: silhouette (Shah 4.3.3) */
  }
  float depth = depth_sum / coverage;
  /* Curved ground (ours; the BTF was taken over a plane): along the view the ground falls away from
   * the tangent plane by s^2 kappa / 2 at a distance s, so the ray, at height h - d cos(theta) in the
   * plane's frame, passes over the blade the plane would give it once d sin^2(theta) kappa / 2 >
   * cos(theta): it leaves the layer first. kappa: the normal's change along the view's tangential
   * direction, from screen derivatives (least squares over x and y). Crests get their silhouette. */
  vec3 t_v = to_eye - N * dot(to_eye, N);
  if (dot(t_v, t_v) > 1e-8) {
    t_v = normalize(t_v);
    float px = dot(dP_dx, t_v), py = dot(dP_dy, t_v);
    float nx = dot(dN_dx, t_v), ny = dot(dN_dy, t_v);
    float kappa = (nx * px + ny * py) / max(px * px + py * py, 1e-20);
    float sin2 = 1.0 - wv.z * wv.z;
    if (kappa > 0.0 && depth * grass.scale.x * sin2 * kappa * 0.5 > wv.z) {
      discard;
    }
  }
  vec3 hit = v_world - to_eye * depth * grass.scale.x;
  vec4 clip = frame.view_proj * vec4(hit, 1.0);
  gl_FragDepth = clip.z / clip.w * 0.5 + 0.5; /* external occlusion by the blade */

  ivec3 li = ivec3(n_l1 - 1);
  vec3 lw = vec3(1.0, 0.0, 0.0);
  vec3 scale = frame.world_color.rgb;
  if (mode == 1) {
    vec3 to_light;
    vec3 radiance = emitter_irradiance(hit, to_light);
    vec3 wl = vec3(dot(to_light, Tg), dot(to_light, Bg), dot(to_light, N));
    if (wl.z <= 0.0 || max(radiance.r, max(radiance.g, radiance.b)) <= 0.0) {
      discard;
    }
    nearest3(wl, 1, li, lw);
    scale = radiance * visibility(hit, N);
  }

  /* Eq. 4.4 per channel, groups of four eigen-textures; Y, Cb, Cr groups follow each other. */
  vec3 ycc = vec3(0.0);
  for (int c = 0; c < 3; c++) {
    int g0 = (c == 0) ? 0 : ((c == 1) ? g.x : g.x + g.y);
    int gn = (c == 0) ? g_y : ((c == 1) ? g.y : g.z);
    float sum = 0.0;
    for (int q = 0; q < gn; q++) {
      int col = (g0 + q) * R;
      vec4 U0 = texelFetch(btf_basis, ivec2(col + tap[0].x, tap[0].y), 0);
      vec4 U1 = texelFetch(btf_basis, ivec2(col + tap[1].x, tap[1].y), 0);
      vec4 U2 = texelFetch(btf_basis, ivec2(col + tap[2].x, tap[2].y), 0);
      vec4 U3 = texelFetch(btf_basis, ivec2(col + tap[3].x, tap[3].y), 0);
      for (int j = 0; j < 3; j++) {
        vec4 Ub = hw[4 * j] * U0 + hw[4 * j + 1] * U1 + hw[4 * j + 2] * U2 + hw[4 * j + 3] * U3;
        int row = vi[j] * n_l1;
        vec4 coef = lw.x * texelFetch(btf_coeffs, ivec2(row + li.x, g0 + q), 0) +
                    lw.y * texelFetch(btf_coeffs, ivec2(row + li.y, g0 + q), 0) +
                    lw.z * texelFetch(btf_coeffs, ivec2(row + li.z, g0 + q), 0);
        sum += vw[j] * dot(Ub, coef);
      }
    }
    ycc[c] = sum / coverage;
  }
  /* btf_compress.YCBCR_TO_RGB (linear BT.601, full range) */
  vec3 rgb = vec3(ycc.x + 1.402 * ycc.z, ycc.x - 0.344136 * ycc.y - 0.714136 * ycc.z, ycc.x + 1.772 * ycc.y);
  out_color = vec4(scale * max(rgb, vec3(0.0)), (mode == 0) ? 1.0 : 0.0);
}
#endif
