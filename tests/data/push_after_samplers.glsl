/* The test-only pass of tests/test_pass_shader.py: its push constants and the sum of its samplers' texels. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  gl_Position = vec4(corner, 0.0, 1.0);
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  float sampled = texelFetch(s0, ivec2(0), 0).r + texelFetch(s1, ivec2(0), 0).r + texelFetch(s2, ivec2(0), 0).r +
                  texelFetch(s3, ivec2(0), 0).r + texelFetch(s4, ivec2(0), 0).r + texelFetch(s5, ivec2(0), 0).r +
                  texelFetch(s6, ivec2(0), 0).r;
  out_color = vec4(float(first), float(second), third, sampled);
}
#endif
