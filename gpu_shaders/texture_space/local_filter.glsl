/* TEXTURE_SPACE local response and combination (Lensch Eq. 15, 12, 9): one point per texel. The
 * texel's source (itself, or across the seam for a border texel) is filtered with its local kernel
 * K' ((2 local_half + 1)^2 entries, row `row` of the kernel table) over the illumination map, and the vertex
 * response B_v / T_p(v) and its share through thin parts are interpolated with the source's barycentrics.
 * Outputs carry alpha 1 so
 * that the display can weigh texels by coverage. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  v_source = source;
  v_row = row;
  v_bary = bary;
  v_verts = verts;
  gl_Position = vec4((texel + 0.5) / atlas_size * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  int width = textureSize(kernels, 0).x;
  int side = 2 * local_half + 1;
  int taps = side * side;
  int base = int(v_row + 0.5) * taps;
  ivec2 centre = ivec2(v_source + 0.5);
  vec3 B_l = vec3(0.0);
  for (int k = 0; k < taps; k++) {
    int e = base + k;
    vec3 K = texelFetch(kernels, ivec2(e % width, e / width), 0).rgb;
    B_l += K * texelFetch(irradiance, centre + ivec2(k % side - local_half, k / side - local_half), 0).rgb;
  }
  vec3 B_g = vec3(0.0);
  vec3 B_t = vec3(0.0);
  for (int c = 0; c < 3; c++) {
    int v = int(v_verts[c] + 0.5);
    ivec2 at = ivec2(v % vertex_width, v / vertex_width);
    B_g += v_bary[c] * texelFetch(B_vertex, at, 0).rgb;
    B_t += v_bary[c] * texelFetch(B_through, at, 0).rgb;
  }
  out_local = vec4(B_l, 1.0);
  out_global = vec4(B_g, 1.0);
  out_through = vec4(B_t, 1.0);
}
#endif
