/* Lookups in the per-emitter distance atlas of pipeline.py (passes with a `light` block and a
 * `shadow_atlas` sampler); p and n in world space. */

/* World size of one shadow texel at rel = p - the light's position: 90 degree faces span 2 r, a spot's
 * fitted face 2 r tan_half (cone.w > 0: blocks.shadow_faces), the directional map spans 2 R. */
float shadow_texel_world(vec3 rel)
{
  bool is_point = light.position_kind.w > 0.5;
  bool fitted = light.cone.w > 0.0;
  return (is_point ? 2.0 * (fitted ? light.cone.w : 1.0) * length(rel) : 2.0 * light.shadow.y) / light.shadow.x;
}

/* Where p falls in the atlas: false outside the directional map or a spot's cone (no light there). x is
 * p's position on its face in texels (continuous), tile the face's first texel in the atlas, and here
 * the quantity the atlas stores, for p: |p - light| (point emitters), the depth along the axis from the
 * shadow origin (directional). */
bool shadow_atlas_point(vec3 p, out vec2 x, out ivec2 tile, out float here)
{
  float texels = light.shadow.x;
  bool is_point = light.position_kind.w > 0.5;
  bool fitted = light.cone.w > 0.0;
  vec3 rel = p - light.position_kind.xyz;
  int face = (is_point && !fitted) ? cube_face(rel) : 0;
  vec4 clip = light.face_view_proj[face] * vec4(p, 1.0);
  vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
  x = uv * texels;
  tile = ivec2(face % 3, face / 3) * int(texels);
  here = is_point ? length(rel) : dot(rel, light.direction.xyz);
  return !(clip.w <= 0.0 || any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))));
}

/* Shadow test: 1 lit, 0 shadowed. */
float visibility(vec3 p, vec3 n)
{
  if (light.shadow.w < 0.5) {
    return 1.0;
  }
  int texels = int(light.shadow.x);
  float texel_world = shadow_texel_world(p - light.position_kind.xyz);
  vec2 x;
  ivec2 tile;
  float here;
  if (!shadow_atlas_point(p + n * light.shadow.z * texel_world, x, tile, here)) {
    return 1.0; /* outside the directional map, or a spot's cone (no light there): unshadowed */
  }
  float stored = texelFetch(shadow_atlas, tile + clamp(ivec2(x), ivec2(0), ivec2(texels - 1)), 0).r;
  return (here - 0.5 * texel_world <= stored) ? 1.0 : 0.0;
}
