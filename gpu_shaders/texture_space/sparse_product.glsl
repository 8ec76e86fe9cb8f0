/* TEXTURE_SPACE global response at the vertices (Lensch Eq. 9, 11, 13): for vertex j,
 * B_j = B^d_j + sum_i F^0_ij E^g_i + sum_P G_jP E_P over row j of the sparse matrix (CSR in float textures;
 * a source index past the vertices is a far cluster P, its power E_P in E_cluster: techniques/texture_space/
 * far_field.py), divided by the surface texture at the vertex, T_p(v_j). One fragment per vertex. Indices are
 * stored as exact floats (below 2^24); a row start as two of them, hi * row_split + lo
 * (techniques/texture_space/model.py ROW_SPLIT), so that F may hold more than 2^24 entries. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  gl_Position = vec4(corner, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
ivec2 entry(int e, int width)
{
  return ivec2(e % width, e / width);
}

int row_start(int j)
{
  ivec2 hi_lo = ivec2(texelFetch(F_indptr, entry(j, textureSize(F_indptr, 0).x), 0).rg + 0.5);
  return hi_lo.x * row_split + hi_lo.y;
}

void main()
{
  ivec2 p = ivec2(gl_FragCoord.xy);
  int j = p.y * vertex_width + p.x;
  if (j >= vertex_count) {
    out_vertex = vec4(0.0);
    out_through = vec4(0.0);
    return;
  }
  ivec2 table = textureSize(F_indices, 0);
  int width = table.x;
  /* The loop and its fetches stay inside the tables whatever a row start holds (the bake is checked
   * when read, texture_space/model.check; this bounds the GPU's work on its own). */
  int begin = max(row_start(j), 0);
  int end = min(row_start(j + 1), table.x * table.y);
  vec3 B = texelFetch(B_direct, p, 0).rgb;
  vec3 B_t = vec3(0.0); /* the light that crossed a thin part: each entry's depth (alpha) ramped in from 2 to 4
                           mean free paths, as the splat shader's through_factor (texture_space/throughput.py,
                           through_share) */
  for (int e = begin; e < end; e++) {
    ivec2 at = entry(e, width);
    int i = clamp(int(texelFetch(F_indices, at, 0).r + 0.5), 0, vertex_count + cluster_count - 1);
    vec3 E;
    if (i < vertex_count) {
      E = texelFetch(E_vertex, ivec2(i % vertex_width, i / vertex_width), 0).rgb;
    }
    else {
      i -= vertex_count;
      E = texelFetch(E_cluster, ivec2(i % vertex_width, i / vertex_width), 0).rgb;
    }
    vec4 F = texelFetch(F_data, at, 0);
    B += F.rgb * E;
    B_t += F.rgb * smoothstep(2.0 * z_r, 4.0 * z_r, vec3(F.a)) * E;
  }
  vec3 T_p = max(texelFetch(T_p_vertex, p, 0).rgb, vec3(1e-4));
  out_vertex = vec4(B / T_p, 1.0);
  out_through = vec4(B_t / T_p, 1.0);
}
#endif
