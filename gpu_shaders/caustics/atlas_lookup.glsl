/* Light-atlas addressing shared by the caustics passes (techniques/caustics/model.py atlas_texels is
 * the NumPy twin): the cube face by the major axis of p - light (point) or the single orthographic
 * face (directional), its clip-space projection, and the texel in the 3 x 2 atlas. */
bool light_atlas_uv(vec3 p, int texels, out int face, out vec2 uv)
{
  bool is_point = light.position_kind.w > 0.5;
  face = is_point ? cube_face(p - light.position_kind.xyz) : 0;
  vec4 clip = light.face_view_proj[face] * vec4(p, 1.0);
  uv = clip.xy / clip.w * 0.5 + 0.5;
  return clip.w > 0.0 && all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0)));
}

ivec2 light_atlas_texel(int face, vec2 uv, int texels)
{
  return ivec2(face % 3, face / 3) * texels + clamp(ivec2(floor(uv * float(texels))), ivec2(0), ivec2(texels - 1));
}
