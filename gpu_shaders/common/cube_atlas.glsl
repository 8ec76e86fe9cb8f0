/* Bordered cube-map atlases: the GLSL twin of translucent_addon/geometry/cubemap.py (GEOCUBE cubes,
 * environment maps). */

/* Face and s, t in [-1, 1] of a direction (OpenGL's cube-map table, ties to the lower axis). */
int atlas_face_st(vec3 d, out vec2 st)
{
  vec3 a = abs(d);
  if (a.x >= a.y && a.x >= a.z) {
    st = (d.x > 0.0) ? vec2(-d.z, -d.y) / a.x : vec2(d.z, -d.y) / a.x;
    return d.x > 0.0 ? 0 : 1;
  }
  if (a.y >= a.z) {
    st = (d.y > 0.0) ? vec2(d.x, d.z) / a.y : vec2(d.x, -d.z) / a.y;
    return d.y > 0.0 ? 2 : 3;
  }
  st = (d.z > 0.0) ? vec2(d.x, -d.y) / a.z : vec2(-d.x, -d.y) / a.z;
  return d.z > 0.0 ? 4 : 5;
}

/* The four texels bilinear filtering blends: lower-left texel and the weights (cubemap._corners). */
ivec2 atlas_corners(int res, vec3 d, int row0, out vec2 f)
{
  vec2 st;
  int face = atlas_face_st(d, st);
  float w = float(res + 2);
  vec2 x = clamp((st + 1.0) * 0.5 * float(res) + 0.5, vec2(0.0), vec2(w - 1.0));
  vec2 x0 = min(floor(x), vec2(w - 2.0));
  f = x - x0;
  return ivec2(face * (res + 2) + int(x0.x), row0 + int(x0.y));
}

vec4 atlas_bilinear(sampler2D atlas, int res, vec3 d, int row0)
{
  vec2 f;
  ivec2 c = atlas_corners(res, d, row0, f);
  vec4 a = texelFetch(atlas, c, 0);
  vec4 b = texelFetch(atlas, c + ivec2(1, 0), 0);
  vec4 e = texelFetch(atlas, c + ivec2(0, 1), 0);
  vec4 g = texelFetch(atlas, c + ivec2(1, 1), 0);
  return mix(mix(a, b, f.x), mix(e, g, f.x), f.y);
}

float atlas_min_x(sampler2D atlas, int res, vec3 d, int row0)
{
  vec2 f;
  ivec2 c = atlas_corners(res, d, row0, f);
  return min(min(texelFetch(atlas, c, 0).x, texelFetch(atlas, c + ivec2(1, 0), 0).x),
             min(texelFetch(atlas, c + ivec2(0, 1), 0).x, texelFetch(atlas, c + ivec2(1, 1), 0).x));
}

