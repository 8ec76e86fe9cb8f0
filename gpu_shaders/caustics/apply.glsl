/* Caustics pass 5 (Shah 5.3.2, last step): receivers seen from the light add rho / pi * E_c, E_c the
 * caustic flux per texel (bilinear in the atlas) over the receiver area that texel covers
 * (techniques/caustics/model.py receiver_patch_area). A point the light does not see directly (another receiver
 * lies in front of it in the receiver atlas) gets none. Additive over the base pass. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  v_color = col;
  gl_Position = frame.view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  int texels = int(caustic.estimate.z + 0.5);
  int face;
  vec2 uv;
  if (!light_atlas_uv(v_world, texels, face, uv)) {
    discard;
  }
  vec3 n = normalize(v_normal); /* either face: |n . l| below, and the atlas test keeps the one the light sees */
  bool is_point = light.position_kind.w > 0.5;
  vec3 rel = v_world - light.position_kind.xyz;
  float r = length(rel);
  vec3 to_light = is_point ? -rel / r : -light.direction.xyz;
  float cos_l = max(abs(dot(n, to_light)), 1.0e-3);
  float texel_world = (is_point ? 2.0 * r : 2.0 * light.shadow.y) / float(texels);
  vec4 seen = texelFetch(receiver_atlas, light_atlas_texel(face, uv, texels), 0);
  if (seen.w < 0.5 || length(seen.xyz - v_world) > 3.0 * texel_world / max(cos_l, 0.1)) {
    discard; /* hidden from the light by another receiver */
  }
  /* Bilinear flux within the face tile. */
  ivec2 tile = ivec2(face % 3, face / 3) * texels;
  vec2 f = uv * float(texels) - 0.5;
  ivec2 i0 = ivec2(floor(f));
  vec2 w = f - vec2(i0);
  vec3 flux = vec3(0.0);
  for (int k = 0; k < 4; k++) {
    ivec2 o = ivec2(k & 1, k >> 1);
    ivec2 q = clamp(i0 + o, ivec2(0), ivec2(texels - 1));
    float wk = (o.x == 1 ? w.x : 1.0 - w.x) * (o.y == 1 ? w.y : 1.0 - w.y);
    flux += wk * texelFetch(caustic_atlas, tile + q, 0).rgb;
  }
  float area;
  if (is_point) {
    vec3 a = abs(rel);
    float major = max(a.x, max(a.y, a.z));
    float minor2 = (dot(a, a) - major * major) / (major * major);
    area = pow(2.0 / float(texels), 2.0) / pow(1.0 + minor2, 1.5) * r * r / cos_l;
  }
  else {
    area = pow(2.0 * light.shadow.y / float(texels), 2.0) / cos_l;
  }
  out_color = vec4(v_color * flux / area / PI, 0.0);
}
#endif
