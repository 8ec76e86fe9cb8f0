/* The materials' surface over what the methods drew (core/surface.py, core/physics/microfacet.py):
 * the Principled BSDF's specular layer, f_s = D G2 F / (4 mu_i mu_o) (Walter et al. 2007 Eq. 20; GGX D, Smith's
 * height-correlated G2, Heitz 2014 Eq. 99) times multiscatter GGX's energy term 1 + F_0 (1 - E_1) / E_1
 * (Turquin 2019), per emitter (mode 1) and for the world (mode 0: E_s(mu_o) times the world's SH radiance around
 * the reflected direction, each band weighed by the lobe, Karis 2013's split sum); in mode 0 also the factor the
 * light below the layer is multiplied by: the colour texture's rho_eff ratio (Cycles colours the subsurface light
 * where it leaves towards the eye, core/surface.py) times the layering weight 1 - E_s(mu_o) (Cycles
 * closure_layering_weight) over the 1 - F(mu_o) the subsurface methods already left through; and the Normal and
 * Depth passes; and the light entering through the normal map against the light entering through the methods'
 * normal, summed over the world and the emitters (``entry``), whose ratio scales what lies below the layer. The
 * shading normal follows a tangent-space normal map (Blender's Normal Map node:
 * N' = normalize(N + strength (N_map - N)), N_map = x T + y B + z N, B = sign N x T). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  v_tangent = vec4(mat3(object.model) * tangent.xyz, tangent.w);
  v_uv = uv;
  v_albedo = albedo;
  v_gloss = gloss;
  gl_Position = frame.view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
/* An image read at uv (texel centres at (i + 0.5) / size): bilinear or the closest texel (mode & 1), repeating or
 * continuing its border (mode & 2); core/surface.sample_bilinear. */
vec4 read_image(sampler2D map, vec2 uv, int mode)
{
  ivec2 size = textureSize(map, 0);
  vec2 q = uv * vec2(size) - 0.5;
  if ((mode & 1) != 0) {
    q = floor(q + 0.5);
  }
  vec2 f = q - floor(q);
  ivec2 i0 = ivec2(floor(q));
  ivec2 a = ivec2(mod(vec2(i0), vec2(size)));
  ivec2 b = ivec2(mod(vec2(i0 + 1), vec2(size)));
  if ((mode & 2) != 0) {
    a = clamp(i0, ivec2(0), size - 1);
    b = clamp(i0 + 1, ivec2(0), size - 1);
  }
  vec4 top = mix(texelFetch(map, a, 0), texelFetch(map, ivec2(b.x, a.y), 0), f.x);
  vec4 bottom = mix(texelFetch(map, ivec2(a.x, b.y), 0), texelFetch(map, b, 0), f.x);
  return mix(top, bottom, f.y);
}

/* E_s(mu_o, roughness, F_0) from microfacet.albedo_table: rows m * 32 + k (F_0 = (m / 15)^2, roughness k / 31),
 * columns mu_o = (j + 0.5) / 32; bilinear in mu and roughness, linear in sqrt(F_0) (microfacet.table_lookup). */
float specular_albedo(float mu, float roughness, float f0)
{
  ivec2 size = textureSize(specular_table, 0);
  int n_r = size.y / 16;
  float x = clamp(mu * float(size.x) - 0.5, 0.0, float(size.x - 1));
  float r = clamp(roughness, 0.0, 1.0) * float(n_r - 1);
  float m = clamp(sqrt(clamp(f0, 0.0, 1.0)), 0.0, 1.0) * 15.0;
  int x0 = min(int(x), size.x - 2), r0 = min(int(r), n_r - 2), m0 = min(int(m), 14);
  float fx = x - float(x0), fr = r - float(r0), fm = m - float(m0);
  float value = 0.0;
  for (int dm = 0; dm < 2; dm++) {
    for (int dr = 0; dr < 2; dr++) {
      int row = (m0 + dm) * n_r + r0 + dr;
      float e = mix(texelFetch(specular_table, ivec2(x0, row), 0).r, texelFetch(specular_table, ivec2(x0 + 1, row), 0).r,
                    fx);
      value += e * (dm == 0 ? 1.0 - fm : fm) * (dr == 0 ? 1.0 - fr : fr);
    }
  }
  return value;
}

/* (1 - E_1) / E_1 from microfacet.energy_table (roughness rows, mu columns). */
float energy_term(float mu, float roughness)
{
  ivec2 size = textureSize(energy_table, 0);
  float x = clamp(mu * float(size.x) - 0.5, 0.0, float(size.x - 1));
  float r = clamp(roughness, 0.0, 1.0) * float(size.y - 1);
  int x0 = min(int(x), size.x - 2), r0 = min(int(r), size.y - 2);
  float fx = x - float(x0), fr = r - float(r0);
  float a = mix(texelFetch(energy_table, ivec2(x0, r0), 0).r, texelFetch(energy_table, ivec2(x0 + 1, r0), 0).r, fx);
  float b = mix(texelFetch(energy_table, ivec2(x0, r0 + 1), 0).r, texelFetch(energy_table, ivec2(x0 + 1, r0 + 1), 0).r,
                fx);
  return mix(a, b, fr);
}

float smith_lambda(float mu, float alpha)
{
  mu = clamp(mu, 1e-6, 1.0);
  float tan2 = (1.0 - mu * mu) / (mu * mu);
  return 0.5 * (-1.0 + sqrt(1.0 + alpha * alpha * tan2));
}

float layer_eta(float f0)
{
  float s = sqrt(clamp(f0, 0.0, 0.999));
  return (1.0 + s) / (1.0 - s);
}

float luminance(vec3 c)
{
  return dot(c, vec3(0.2126, 0.7152, 0.0722));
}

void main()
{
  vec3 n = normalize(v_normal);
  vec3 n_g = cross(dFdx(v_world), dFdy(v_world)); /* the facet's plane; derivatives before any discard */
  if (!facing_out(object.shading)) {
    n = -n;
  }
  vec3 n_s = n; /* the interpolated normal, as the methods drew with it */
  float strength = v_gloss.z;
  bool mapped_normal = normal_mode >= 0 && strength > 0.0;
  if (mapped_normal) {
    vec3 t = v_tangent.xyz - n * dot(n, v_tangent.xyz);
    if (dot(t, t) > 1e-20) {
      t = normalize(t);
      vec3 b = v_tangent.w * cross(n, t);
      vec3 ts = read_image(normal_map, v_uv, normal_mode).rgb * 2.0 - 1.0;
      vec3 mapped = normalize(ts.x * t + ts.y * b + ts.z * n);
      n = normalize(n + strength * (mapped - n));
    }
  }
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, v_world);
  float mu_o = dot(n, to_eye);
  float roughness = v_gloss.x;
  float f0 = v_gloss.y;
  float weight = v_gloss.w; /* 1, or a medium's own boundary weighed by the painted translucency mask */
  bool glossy = weight > 0.0 && f0 > 0.0;
  float alpha = max(roughness * roughness, 1e-3);
#ifdef SURFACE_WORLD
  float mu = clamp(mu_o, 1e-4, 1.0);
  float E_s = glossy ? weight * specular_albedo(mu, roughness, f0) : 0.0;
  vec3 specular = vec3(0.0);
  if (glossy) {
    float s2 = 2.0 * alpha * alpha; /* microfacet.sh_lobe_kernel */
    vec3 kernel = vec3(1.0, exp(-s2), exp(-3.0 * s2));
    specular = E_s * world_irradiance(reflect(-to_eye, n), kernel);
  }
  vec3 colour = v_albedo.a > 0.0 ? read_image(albedo_map, v_uv, albedo_mode).rgb : v_albedo.rgb;
  /* the layer's weight over what the methods left through: (1 - E_s) / (1 - F(mu_o, eta)), the methods' F with
   * their own normal (eta = 0: Lambert, none); at most MAX_SPLIT where both tend to 0 at grazing angles */
  const float MAX_SPLIT = 4.0;
  float mu_s = clamp(dot(n_s, to_eye), 1e-4, 1.0);
  float left = base_eta > 0.0 ? 1.0 - fresnel_dielectric(mu_s, base_eta) : 1.0;
  float split = (glossy && roughness > 0.0) ? min((1.0 - E_s) / max(left, 1e-4), MAX_SPLIT) : 1.0;
  out_specular = vec4(specular, 0.0);
  /* less 1: a cleared target holds factor 1; alpha 1 on a subsurface object (the Subsurface pass's mask) */
  out_factor = vec4(colour * split - 1.0, base_eta > 0.0 ? 1.0 : 0.0);
  float depth = frame.camera_position.w > 0.5 ? dot(v_world - frame.camera_position.xyz, frame.camera_forward.xyz) :
                                                 -(frame.view * vec4(v_world, 1.0)).z;
  out_gbuffer = vec4(n, depth);
  /* the world's light entering through the mapped normal and through the methods' (entry: the factor's x / y);
   * z: over how many pixels light entering a medium spreads before it leaves (its diffusion length, at this
   * depth), over which the composite averages the two */
  float footprint = frame.camera_position.w > 0.5 ? 2.0 / (frame.proj[1][1] * pixels_y) :
                                                    2.0 * depth / (frame.proj[1][1] * pixels_y);
  out_entry = mapped_normal ? vec4(luminance(world_irradiance(n, LAMBERT_KERNEL)),
                                   luminance(world_irradiance(n_s, LAMBERT_KERNEL)), spread / footprint, 0.0) :
                              vec4(0.0);
#else
  vec3 to_light;
  vec3 radiance = emitter_irradiance(v_world, to_light);
  float mu_i = dot(n, to_light);
  /* a facet facing away from the light is in its own shadow (base_lighting.glsl says why) */
  if (dot(n_g, to_light) * dot(n_g, n_s) <= 0.0 || max(radiance.r, max(radiance.g, radiance.b)) <= 0.0) {
    discard;
  }
  vec3 V = radiance * visibility(v_world, n_s);
  /* this light entering through the mapped normal and through the methods' (Cycles' subsurface exit BSDF takes
   * the mapped normal, kernel/integrator/subsurface.h): their ratio scales what lies below the layer */
  out_entry = mapped_normal ? vec4(luminance(V) * max(mu_i, 0.0), luminance(V) * max(dot(n_s, to_light), 0.0),
                                   0.0, 0.0) :
                              vec4(0.0);
  if (!glossy || roughness * roughness < 1e-3 || mu_i <= 0.0 || mu_o <= 0.0) {
    out_specular = vec4(0.0);
    return;
  }
  vec3 h = normalize(to_light + to_eye);
  float mu_h = max(dot(n, h), 0.0);
  float a2 = alpha * alpha;
  float d = mu_h * mu_h * (a2 - 1.0) + 1.0;
  float D = a2 / (PI * d * d);
  float G2 = 1.0 / (1.0 + smith_lambda(mu_o, alpha) + smith_lambda(mu_i, alpha));
  float F = fresnel_dielectric(max(dot(to_eye, h), 0.0), layer_eta(f0));
  float f_mu_i = D * G2 * F / (4.0 * mu_o) * (1.0 + f0 * energy_term(mu_o, roughness));
  out_specular = vec4(weight * f_mu_i * V, 0.0);
#endif
}
#endif
