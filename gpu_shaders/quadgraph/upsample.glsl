/* QUADGRAPH level start (Wang Eq. 10): phi at a node of the finer level from its b coarser nodes
 * (b = 4 for surface nodes, 8 for inner nodes) with normalised Shepard weights 1/d^2. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  gl_Position = vec4(corner, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 i0 = texelFetch(up_index0, p, 0);
  vec4 i1 = texelFetch(up_index1, p, 0);
  vec4 w0 = texelFetch(up_weight0, p, 0);
  vec4 w1 = texelFetch(up_weight1, p, 0);
  vec3 sum = vec3(0.0);
  for (int j = 0; j < 4; j++) {
    if (w0[j] > 0.0) {
      sum += w0[j] * texelFetch(coarse_phi, qg_texel(int(i0[j] + 0.5), coarse_blocks_per_row), 0).rgb;
    }
    if (w1[j] > 0.0) {
      sum += w1[j] * texelFetch(coarse_phi, qg_texel(int(i1[j] + 0.5), coarse_blocks_per_row), 0).rgb;
    }
  }
  out_phi = vec4(sum, 1.0);
}
#endif
