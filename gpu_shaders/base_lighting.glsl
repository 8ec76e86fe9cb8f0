/* Base pass: Lambert shading of the material's base colour.
 * mode 0: world term rho * L_world (also lays down depth);
 * mode 1: one emitter, rho / pi * E * V, added with additive blending.
 * E follows translucent_addon/render/lights.py (Cycles' light units), V is a
 * hard shadow-map test with a normal offset of shadow.z texels. */
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
#define PI 3.14159265358979

int cube_face(vec3 d)
{
  vec3 a = abs(d);
  if (a.x >= a.y && a.x >= a.z) {
    return d.x > 0.0 ? 0 : 1;
  }
  if (a.y >= a.z) {
    return d.y > 0.0 ? 2 : 3;
  }
  return d.z > 0.0 ? 4 : 5;
}

float visibility(vec3 p, vec3 n)
{
  if (light.shadow.w < 0.5) {
    return 1.0;
  }
  float texels = light.shadow.x;
  bool is_point = light.position_kind.w > 0.5;
  vec3 rel = p - light.position_kind.xyz;
  /* World size of one shadow texel at p: 90 degree faces span 2 r, the
   * directional map spans 2 R. */
  float texel_world = (is_point ? 2.0 * length(rel) : 2.0 * light.shadow.y) / texels;
  vec3 p_off = p + n * light.shadow.z * texel_world;
  rel = p_off - light.position_kind.xyz;
  int face = is_point ? cube_face(rel) : 0;
  vec4 clip = light.face_view_proj[face] * vec4(p_off, 1.0);
  vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) {
    return 1.0; /* outside the directional map: unshadowed */
  }
  ivec2 tile = ivec2(face % 3, face / 3);
  ivec2 texel = tile * int(texels) + clamp(ivec2(uv * texels), ivec2(0), ivec2(int(texels) - 1));
  float stored = texelFetch(shadow_atlas, texel, 0).r;
  float here = is_point ? length(rel) : dot(rel, light.direction.xyz);
  return (here - 0.5 * texel_world <= stored) ? 1.0 : 0.0;
}

void main()
{
  vec3 n = normalize(v_normal);
  if (!gl_FrontFacing) {
    n = -n;
  }
  if (mode == 0) {
    out_color = vec4(v_color * frame.world_color.rgb, 1.0);
    return;
  }
  vec3 irradiance;
  vec3 to_light;
  if (light.position_kind.w < 0.5) {
    to_light = -light.direction.xyz;
    irradiance = light.radiance.rgb * max(dot(n, to_light), 0.0);
  }
  else {
    vec3 d = light.position_kind.xyz - v_world;
    float dist = length(d);
    to_light = d / dist;
    float cos_axis = dot(-to_light, light.direction.xyz);
    float lobe = 1.0;
    if (light.cone.x >= -1.0) {
      lobe = (light.cone.y > 0.0) ? smoothstep(0.0, 1.0, (cos_axis - light.cone.x) / light.cone.y) :
                                    float(cos_axis > light.cone.x);
    }
    if (light.cone.z > 0.5) {
      lobe *= max(cos_axis, 0.0);
    }
    irradiance = light.radiance.rgb * lobe * max(dot(n, to_light), 0.0) / (dist * dist);
  }
  float v = (max(irradiance.r, max(irradiance.g, irradiance.b)) > 0.0) ? visibility(v_world, n) : 0.0;
  out_color = vec4(v_color * irradiance * v / PI, 0.0);
}
#endif
