/* TEXTURE_SPACE display (Lensch Eq. 1, 14): the displayed mesh with its atlas coordinates reads
 * the local and the global radiosity (bilinear, weighted by texel coverage) and leaves
 * L = F_t(w_o) / pi (a(cos_o) (B^l + T_p (B^g - B^t)) + M(cos_o) T_p B^t) (F_r(w_o) L_world: the surface layer), a the angular law of
 * the light leaving (physics/angular_law.py; its emitters' light entered weighed by a(cos_i) in ts_illumination),
 * M the diffusion mode's law of the share B^t that crossed a thin part (angular_law.through_exit). */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  v_color = col;
  v_uv = uv;
  gl_Position = frame.view_proj * world;
  /* A subdivided display lies on the base pass's triangles but rounds differently: draw it a hair
   * nearer (1e-5 of the depth range) so that the depth test keeps all of it. */
  gl_Position.z -= 1e-5 * gl_Position.w;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
/* Bilinear read at texel coordinates p (texel centres at +0.5); texels carry alpha = coverage. */
vec4 bilinear(sampler2D map, vec2 p)
{
  ivec2 size = textureSize(map, 0);
  vec2 q = p - 0.5;
  ivec2 i = ivec2(floor(q));
  vec2 f = q - floor(q);
  ivec2 i1 = clamp(i + 1, ivec2(0), size - 1);
  i = clamp(i, ivec2(0), size - 1);
  vec4 a = mix(texelFetch(map, i, 0), texelFetch(map, ivec2(i1.x, i.y), 0), f.x);
  vec4 b = mix(texelFetch(map, ivec2(i.x, i1.y), 0), texelFetch(map, i1, 0), f.x);
  return mix(a, b, f.y);
}

void main()
{
  vec3 n = normalize(v_normal);
  if (!facing_out(object.shading)) {
    n = -n;
  }
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, v_world);
  float cos_o = max(dot(n, to_eye), 0.0);
  float F_r = fresnel_dielectric(cos_o, eta);
  vec4 l = bilinear(local_map, v_uv);
  vec4 g = bilinear(global_map, v_uv);
  vec4 t = bilinear(through_map, v_uv);
  vec3 B = (l.a > 0.0 ? l.rgb / l.a : vec3(0.0)) + v_color * (g.a > 0.0 ? g.rgb / g.a : vec3(0.0));
  /* The corrected kernels are negative where the vertex response overshoots; at a terminator the sum
   * can dip below zero in a short channel. Radiosity cannot. */
  B = max(B, vec3(0.0));
  /* What crossed a thin part leaves by the diffusion mode's law M (exit_table), the rest by the angular law. */
  vec3 B_t = clamp(v_color * (t.a > 0.0 ? t.rgb / t.a : vec3(0.0)), vec3(0.0), B);
  vec3 L = cosine_lerp(angular_table, cos_o) * (B - B_t) + cosine_lerp(exit_table, cos_o) * B_t;
  out_color = vec4((1.0 - F_r) / PI * L, 1.0); /* the world's reflection: the surface layer's */
}
#endif
