/* QUADGRAPH display (Wang Eq. 4, 7): each displayed vertex interpolates the exitance
 * B = (1 - F_dr) phi_s / (2 (1 + F_dr)) of its four surface nodes (Shepard weights from the
 * bake; physics/diffusion.py says why the (1 - F_dr)), and the fragment leaves
 * L = F_t(w_o) / pi B on the original mesh (F_r(w_o) L_world: the surface layer), blended over the
 * base pass's Lambert by the painted translucency mask (alpha). q carries its painted factor. The
 * surface term of qg_single (single and local multiple scattering), summed over the emitters in a
 * screen target, is added to L, with the painted factor on the light entering (mask x glow x tint)
 * interpolated like B; B gives up the exitance the term takes over where light enters (``loss``:
 * single_scattering.exitance_loss, times ``loss_scale``, diffusion.held_source_gain: what more the
 * graph reflects where a surface link is shorter than z_0 and the source is held at the inner node), and the world's light gives up its flat-face response too
 * (``loss_world``), drawn with a half-space's law under uniform light (``world_law``:
 * single_scattering.uniform_light_table; one texel of 1 where the surface term is off: Wang's
 * display). What B keeps then, light that entered elsewhere and crossed the medium, is drawn
 * Lambertian. */
#ifdef GPU_VERTEX_SHADER
void main()
{
  vec4 world = object.model * vec4(pos, 1.0);
  v_world = world.xyz;
  v_normal = mat3(object.normal_matrix) * nor;
  vec3 B = vec3(0.0);
  vec3 factor = vec3(0.0);
  vec3 taken = vec3(0.0);
  vec3 taken_world = vec3(0.0);
  vec3 held_world = vec3(0.0);
  vec3 gain_mix = vec3(0.0);
  for (int j = 0; j < 4; j++) {
    ivec2 t = qg_texel(int(links[j] + 0.5), blocks_per_row);
    vec3 phi_s = texelFetch(phi, t, 0).rgb;
    vec3 f = texelFetch(q_factor, t, 0).rgb;
    vec3 gain = texelFetch(loss_scale, t, 0).rgb;
    vec3 world = link_weights[j] * texelFetch(loss_world, t, 0).rgb * f;
    B += link_weights[j] * phi_s;
    taken += link_weights[j] * texelFetch(loss, t, 0).rgb * f * gain;
    taken_world += world;
    held_world += world * (gain - 1.0);
    factor += link_weights[j] * f;
    gain_mix += link_weights[j] * gain;
  }
  v_factor = factor;
  v_gain = gain_mix;
  /* Where light enters, the graph's flat face reflects gain R q (the source held too shallow): the
   * emitters' gain R q goes to the surface term, the world's R q_world to its half-space law, and the
   * rest of the world's, (gain - 1) R q_world, is the graph's own excess, drawn by neither. */
  B = max((1.0 - F_dr) * B / (2.0 * (1.0 + F_dr)) - held_world, vec3(0.0));
  v_world_local = min(taken_world, max(B - taken, vec3(0.0)));
  v_radiosity = max(B - taken - taken_world, vec3(0.0));
  v_mask = mask;
  gl_Position = frame.view_proj * world;
}
#endif

#ifdef GPU_FRAGMENT_SHADER
/* The single-scattering target around this pixel, 3 x 3 binomial weights over the pixels whose surface
 * lies within four pixel widths of this one in depth (alpha holds the eye's distance, 0 where no
 * QUADGRAPH surface is): a rim lit at grazing angles is a band thinner than a pixel, and where the view
 * ray's chord through it changes from pixel to pixel one sample each drew it as dotted lines. */
vec3 surface_term(vec3 p, out vec3 spread)
{
  bool ortho = frame.camera_position.w > 0.5;
  float here = eye_distance(frame.camera_position, frame.camera_forward, p);
  ivec2 size = textureSize(single, 0);
  float depth = ortho ? 1.0 : -(frame.view * vec4(p, 1.0)).z;
  float tolerance = 8.0 * depth / (frame.proj[1][1] * float(size.y));
  ivec2 c = ivec2(gl_FragCoord.xy);
  vec3 sum = vec3(0.0), sum_spread = vec3(0.0);
  float weight = 0.0;
  for (int k = 0; k < 9; k++) {
    ivec2 o = ivec2(k % 3 - 1, k / 3 - 1);
    vec4 s = texelFetch(single, clamp(c + o, ivec2(0), size - 1), 0);
    float w = float((2 - abs(o.x)) * (2 - abs(o.y)));
    if (abs(s.a - here) <= tolerance) {
      sum += w * s.rgb;
      sum_spread += w * texelFetch(spread_target, clamp(c + o, ivec2(0), size - 1), 0).rgb;
      weight += w;
    }
  }
  spread = weight > 0.0 ? sum_spread / weight : vec3(0.0);
  return weight > 0.0 ? sum / weight : vec3(0.0);
}

void main()
{
  vec3 n = normalize(v_normal);
  if (!facing_out(object.shading)) {
    n = -n;
  }
  vec3 to_eye = direction_to_eye(frame.camera_position, frame.camera_forward, v_world);
  float mu_o = max(dot(n, to_eye), 0.0);
  float F_r = fresnel_dielectric(mu_o, eta);
  vec3 spread;
  vec3 L_single = surface_term(v_world, spread) * v_factor;
  /* B gives up the terminator's spread too where the graph carries it (its lateral links drew the light
   * that entered beside this point, which the surface term's mu_eff draws again): at most all of B. */
  vec3 B = max(v_radiosity - spread * v_factor * v_gain, vec3(0.0));
  vec3 L_diffusion = (1.0 - F_r) / PI * (B + table_lerp(world_law, mu_o) * v_world_local);
  /* display_output (tests): 0 all, 1 the diffusion alone, 2 or 3 the surface term alone (qg_single
   * drew single scattering alone, or the local multiple scattering alone) */
  vec3 L = L_diffusion + L_single; /* the world's reflection F_r L_world: the surface layer's */
  if (display_output == 1) {
    L = L_diffusion;
  }
  else if (display_output >= 2) {
    L = L_single;
  }
  out_color = vec4(L, clamp(v_mask, 0.0, 1.0));
}
#endif
