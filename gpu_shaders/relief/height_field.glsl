/* Height-field pass (Shah ch. 3): a mesh displaced per pixel by a height map over its UVs. The view
 * ray enters the layer (depth 0 at the polygon, 1 at black, `relief.depth` scene units down along the
 * normal) and interval mapping (or relief mapping) finds its first hit (relief/interval_search.glsl, NumPy twin
 * techniques/relief/model.py); the hit's depth is written (the surface sorts with everything else),
 * its normal comes from the height map, and in the emitters' passes a search toward the light shadows
 * it. Mode 0 is the uniform world, mode 1 one emitter; relief.params.w = 1 writes (hit u, hit v, hit
 * depth, refinements) instead of a colour (tests). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  v_tangent_u = mat3(object.model) * tangent_u;
  v_tangent_v = mat3(object.model) * tangent_v;
  v_uv = uv;
  v_color = col;
  gl_Position = frame.view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
/* Components (a, b) of a vector's part in the tangent plane on the (unnormalised) frame T, B: the
 * least-squares solution of a T + b B = w. */
vec2 in_frame(vec3 w, vec3 T, vec3 B)
{
  float tt = dot(T, T), tb = dot(T, B), bb = dot(B, B);
  float det = tt * bb - tb * tb;
  vec2 rhs = vec2(dot(w, T), dot(w, B));
  return (abs(det) > 1e-30) ? vec2(bb * rhs.x - tb * rhs.y, tt * rhs.y - tb * rhs.x) / det : vec2(0.0);
}

void main()
{
  vec3 N = normalize(v_normal);
  if (!facing_out(object.shading)) {
    N = -N;
  }
  vec3 T = v_tangent_u;
  vec3 B = v_tangent_v;
  float depth_scale = relief.params.x; /* scene units from height 1 to height 0 */
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, v_world);
  float vn = max(dot(to_eye, N), 1e-3);
  /* One unit of layer depth is depth_scale / vn along the ray, which moves the ray sideways by
   * -to_eye_tangential * depth_scale / vn: in UV units through the frame. */
  vec2 dir_uv = -in_frame(to_eye - N * dot(to_eye, N), T, B) * depth_scale / vn;
  int iterations;
  vec3 hit = hf_intersect(height_map, v_uv, dir_uv, int(relief.params.y + 0.5), int(relief.params.z + 0.5),
                          1e-3, int(relief.mode.x + 0.5), iterations);
  float t_hit = hit.z;
  vec3 p_hit = v_world - to_eye * (t_hit * depth_scale / vn);
  vec4 clip = frame.view_proj * vec4(p_hit, 1.0);
  gl_FragDepth = clip.z / clip.w * 0.5 + 0.5;
  if (relief.params.w > 0.5) {
    if (mode == 1) {
      discard; /* written once, by the world pass */
    }
    out_color = vec4(hit.xy, t_hit, float(iterations));
    return;
  }
  /* Normal of P(u, v) = P0 + T u + B v - N depth_scale D(u, v), D = 1 - height (central differences). */
  vec2 texel = 1.0 / vec2(textureSize(height_map, 0));
  float Du = (hf_depth(height_map, hit.xy + vec2(texel.x, 0.0)) - hf_depth(height_map, hit.xy - vec2(texel.x, 0.0))) /
             (2.0 * texel.x);
  float Dv = (hf_depth(height_map, hit.xy + vec2(0.0, texel.y)) - hf_depth(height_map, hit.xy - vec2(0.0, texel.y))) /
             (2.0 * texel.y);
  vec3 n = normalize(cross(T - N * depth_scale * Du, B - N * depth_scale * Dv));
  if (dot(n, N) < 0.0) {
    n = -n;
  }
  if (mode == 0) {
    out_color = vec4(v_color * world_irradiance(n, LAMBERT_KERNEL) / PI, 1.0);
    return;
  }
  vec3 to_light;
  vec3 radiance = emitter_irradiance(p_hit, to_light);
  float cos_i = dot(n, to_light);
  float ln = dot(to_light, N);
  if (cos_i <= 0.0 || ln <= 0.0 || max(radiance.r, max(radiance.g, radiance.b)) <= 0.0) {
    discard;
  }
  /* Other objects' shadows, tested where the ray toward the light leaves the layer: the shadow map holds
   * the undisplaced polygon, which would otherwise shadow every point below it. */
  float V = visibility(p_hit + to_light * (t_hit * depth_scale / ln), N);
  if (relief.mode.y > 0.5) {
    /* Climbing one unit of depth toward the light moves depth_scale / ln along it. */
    vec2 light_uv = in_frame(to_light - N * ln, T, B) * depth_scale / ln;
    V *= hf_self_shadow(height_map, hit.xy, t_hit, light_uv, 16, 1e-3);
  }
  out_color = vec4(v_color * radiance * cos_i * V / PI, 0.0);
}
#endif
