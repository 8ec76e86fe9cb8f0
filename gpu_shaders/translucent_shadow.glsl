/* Shadow test against the per-emitter distance atlas of pipeline.py (passes with a `light` block
 * and a `shadow_atlas` sampler). 1 lit, 0 shadowed; p and n in world space. */
float visibility(vec3 p, vec3 n)
{
  if (light.shadow.w < 0.5) {
    return 1.0;
  }
  float texels = light.shadow.x;
  bool is_point = light.position_kind.w > 0.5;
  vec3 rel = p - light.position_kind.xyz;
  /* World size of one shadow texel at p: 90 degree faces span 2 r, a spot's fitted face 2 r tan_half
   * (cone.w > 0: blocks.shadow_faces), the directional map spans 2 R. */
  bool fitted = light.cone.w > 0.0;
  float texel_world = (is_point ? 2.0 * (fitted ? light.cone.w : 1.0) * length(rel) : 2.0 * light.shadow.y) / texels;
  vec3 p_off = p + n * light.shadow.z * texel_world;
  rel = p_off - light.position_kind.xyz;
  int face = (is_point && !fitted) ? cube_face(rel) : 0;
  vec4 clip = light.face_view_proj[face] * vec4(p_off, 1.0);
  vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
  if (clip.w <= 0.0 || any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) {
    return 1.0; /* outside the directional map, or a spot's cone (no light there): unshadowed */
  }
  ivec2 tile = ivec2(face % 3, face / 3);
  ivec2 texel = tile * int(texels) + clamp(ivec2(uv * texels), ivec2(0), ivec2(int(texels) - 1));
  float stored = texelFetch(shadow_atlas, texel, 0).r;
  float here = is_point ? length(rel) : dot(rel, light.direction.xyz);
  return (here - 0.5 * texel_world <= stored) ? 1.0 : 0.0;
}

