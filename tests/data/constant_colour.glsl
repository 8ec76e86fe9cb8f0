/* The test-only technique of tests/test_technique_plugin.py: its meshes in one colour, over the base. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  gl_Position = frame.view_proj * (object.model * vec4(pos, 1.0));
}
#endif

#ifdef GPU_FRAGMENT_SHADER
void main()
{
  out_color = colour;
}
#endif
