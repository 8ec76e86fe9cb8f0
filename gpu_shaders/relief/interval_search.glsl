// Interval mapping (Shah's thesis ch. 3; Risser, Shah & Pattanaik, JGT 2007) and relief mapping
// (Policarpo et al. 2005) of a height field: a function library, GLSL 3.30 compatible, no #version, no
// uniforms, no main. NumPy twin: translucent_addon/techniques/relief/model.py (same conventions, same
// steps; tests/test_interval_mapping.py checks that they agree).
//
// Conventions:
//   hmap    height in [0, 1] in .r, 1 = top of the layer. Sampled bilinearly with wrap by hf_depth itself
//           (texelFetch: any sampler state, full-precision weights, as the NumPy twin). Texel i covers
//           [i/N, (i+1)/N), centre (i+0.5)/N.
//   depth   D(uv) = 1 - height(uv), downward from the top of the layer, in layer thicknesses, in [0, 1].
//   ray     enters the layer at its top (depth 0) at uv0; at ray depth t in [0, 1] it is at uv0 + t * dir_uv.
//           dir_uv = -V.xy / V.z * depth_scale for a tangent-space V from the surface to the eye.
//   g(t)    = t - D(uv0 + t * dir_uv): < 0 above the surface, >= 0 on or below. g(0) <= 0, g(1) >= 0.
//   stop    after the first iteration whose new point has |g| < threshold (e.g. 1e-3), or after max_iter
//           (the paper's 10). One iteration = one new height sample. The hit is the last point evaluated.

float hf_depth(sampler2D hmap, vec2 uv)
{
    ivec2 size = textureSize(hmap, 0);
    vec2 t = uv * vec2(size) - 0.5;
    vec2 f = t - floor(t);
    ivec2 i0 = ivec2(floor(t));
    ivec2 a = ((i0 % size) + size) % size;
    ivec2 b = (((i0 + 1) % size) + size) % size;
    float h00 = texelFetch(hmap, ivec2(a.x, a.y), 0).r;
    float h10 = texelFetch(hmap, ivec2(b.x, a.y), 0).r;
    float h01 = texelFetch(hmap, ivec2(a.x, b.y), 0).r;
    float h11 = texelFetch(hmap, ivec2(b.x, b.y), 0).r;
    return 1.0 - mix(mix(h00, h10, f.x), mix(h01, h11, f.x), f.y);
}

// Uniform linear search (Shah 3.3 step 1, as relief mapping): ray depths t_k = k / steps, k = 1..steps; the
// first sample on or below the surface is the lower bound, the previous one (t_0 = 0) the upper bound.
void hf_linear_search(sampler2D hmap, vec2 uv0, vec2 dir_uv, int steps,
                      out float t_up, out float d_up, out float t_lo, out float d_lo)
{
    t_up = 0.0;
    d_up = hf_depth(hmap, uv0);
    t_lo = 1.0;
    d_lo = 0.0;
    for (int k = 1; k <= steps; ++k) {
        float t = float(k) / float(steps);
        float d = hf_depth(hmap, uv0 + t * dir_uv);
        if (t >= d) {
            t_lo = t;
            d_lo = d;
            break;
        }
        t_up = t;
        d_up = d;
    }
}

// Shah Eq. 3.1-3.6 in the slice x = ray depth, y = depth: view ray x - y = 0 (A_view = 1, B_view = -1);
// line through the bound samples A_line = y_U - y_L (3.3), B_line = x_L - x_U (3.4),
// C_line = -B_line y_U - A_line x_U (3.5); x = C_line B_view / (A_view B_line - A_line B_view) (3.6).
// The regula-falsi step (Eq. 3.8-3.18), clamped into the bracket.
float hf_interval_point(float t_up, float d_up, float t_lo, float d_lo)
{
    float a_line = d_up - d_lo;
    float b_line = t_lo - t_up;
    float c_line = -b_line * d_up - a_line * t_up;
    float den = b_line + a_line;  // = g_lo - g_up >= 0
    float x = den > 0.0 ? -c_line / den : t_up;
    return clamp(x, t_up, t_lo);
}

// Relief mapping: the midpoint of the bracket.
float hf_binary_point(float t_up, float d_up, float t_lo, float d_lo)
{
    return 0.5 * (t_up + t_lo);
}

// Refine a bracket: mode 0 = interval mapping (Eq. 3.6), 1 = relief mapping (midpoint). Returns
// vec3(hit uv, hit ray depth); iterations in 1..max_iter; converged: |g| < threshold was reached.
vec3 hf_refine(sampler2D hmap, vec2 uv0, vec2 dir_uv, float t_up, float d_up, float t_lo, float d_lo,
               int max_iter, float threshold, int mode, out int iterations, out bool converged)
{
    float t_hit = t_lo;
    iterations = max_iter;
    converged = false;
    for (int it = 1; it <= max_iter; ++it) {
        float t = mode == 0 ? hf_interval_point(t_up, d_up, t_lo, d_lo) : hf_binary_point(t_up, d_up, t_lo, d_lo);
        float d = hf_depth(hmap, uv0 + t * dir_uv);
        float g = t - d;
        if (g < 0.0) {  // new upper bound, else new lower bound: the bracket is kept
            t_up = t;
            d_up = d;
        } else {
            t_lo = t;
            d_lo = d;
        }
        t_hit = t;
        if (abs(g) < threshold) {
            iterations = it;
            converged = true;
            break;
        }
    }
    return vec3(uv0 + t_hit * dir_uv, t_hit);
}

vec3 hf_intersect_full(sampler2D hmap, vec2 uv0, vec2 dir_uv, int linear_steps, int max_iter, float threshold,
                       int mode, out int iterations, out bool converged)
{
    float t_up, d_up, t_lo, d_lo;
    hf_linear_search(hmap, uv0, dir_uv, linear_steps, t_up, d_up, t_lo, d_lo);
    return hf_refine(hmap, uv0, dir_uv, t_up, d_up, t_lo, d_lo, max_iter, threshold, mode, iterations, converged);
}

// Linear search + refinement (mode 0 = interval, 1 = relief). Returns vec3(hit uv, hit ray depth).
vec3 hf_intersect(sampler2D hmap, vec2 uv0, vec2 dir_uv, int linear_steps, int max_iter, float threshold,
                  int mode, out int iterations)
{
    bool converged;
    return hf_intersect_full(hmap, uv0, dir_uv, linear_steps, max_iter, threshold, mode, iterations, converged);
}

// Visibility (1 lit, 0 shadowed) of the point (uv, depth) toward the light: linear search up the light ray,
// uv + s * light_uv at depth (depth - s), s = depth * k / steps, k = 1..steps; shadowed where the surface is
// above it, D < depth - s - bias. light_uv = L.xy / L.z * depth_scale (uv step per unit of depth climbed).
float hf_self_shadow(sampler2D hmap, vec2 uv, float depth, vec2 light_uv, int steps, float bias)
{
    for (int k = 1; k <= steps; ++k) {
        float s = depth * (float(k) / float(steps));
        if (hf_depth(hmap, uv + s * light_uv) < depth - s - bias) {
            return 0.0;
        }
    }
    return 1.0;
}
