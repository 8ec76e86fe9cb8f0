/* GEOCUBE (Chan & Wang 2005): bordered cube atlases and the cone-propelled exit search.
 * Twin of techniques/geocube/model.py, line by line (the atlas lookups are in common/cube_atlas.glsl).
 * Needs: samplers gc_cones (d, cos A, cos B, R_C), gc_normals (N), gc_centres (O, D per cube) and
 * env_atlas; the GeocubeData block `gc`. */

/* Chan & Wang, appendix: C*(mu, gamma) and S*(f, gamma), evaluated (cheaper than a table fetch today). */
float c_star(float mu, float gamma)
{
  float s_mu = sqrt(max(1.0 - mu * mu, 0.0));
  return s_mu / max(gamma * s_mu + mu * sqrt(max(1.0 - gamma * gamma, 0.0)), 1e-30);
}

float s_star(float f, float gamma)
{
  return sqrt(max(1.0 - f * f * (1.0 - gamma * gamma), 0.0)) - f * gamma;
}

/* Appendix C(f, h, a, n, mu): the nearer of the lateral surface and the base plane of a unit cone. */
float cone_step(float f, vec3 h, vec3 a, vec3 n, float mu)
{
  float ha = dot(h, a);
  float hn = dot(h, n);
  float lateral = (ha < mu) ? (1.0 - f) * c_star(mu, -ha) : 1e30;
  float base = (hn > 1e-12) ? f * dot(a, n) / hn : 1e30;
  float s = min(lateral, base);
  return (s < 1e29) ? s : 0.0;
}

int gc_res()
{
  return int(gc.params.x + 0.5);
}

vec4 gc_centre(int cube)
{
  return texelFetch(gc_centres, ivec2(cube, 0), 0);
}

vec4 gc_fetch(int cube, vec3 q)
{
  return atlas_bilinear(gc_cones, gc_res(), q, cube * (gc_res() + 2));
}

vec3 gc_normal(int cube, vec3 q)
{
  return normalize(atlas_bilinear(gc_normals, gc_res(), q, cube * (gc_res() + 2)).xyz);
}

bool gc_inside(int cube, vec3 p)
{
  vec4 o = gc_centre(cube);
  vec3 q = p - o.xyz;
  float l = length(q);
  return l < gc_fetch(cube, q).x || l < o.w;
}

/* geocube/model.py surely_inside_cube: inside by a texel's footprint under the nearest of four texels. */
bool gc_surely_inside(int cube, vec3 p)
{
  vec4 o = gc_centre(cube);
  vec3 q = p - o.xyz;
  float l = length(q);
  float d_min = atlas_min_x(gc_cones, gc_res(), q, cube * (gc_res() + 2));
  return l < d_min * (1.0 - 1.0 / float(gc_res())) || l < o.w;
}

/* Sec. 2.3: the cube that sees p inside, nearest the plane through p perpendicular to p - O; -1: none. */
int gc_switch(int cube, vec3 p)
{
  vec3 w_hat = normalize(gc_centre(cube).xyz - p);
  int best = -1;
  float best_dist = 1e30;
  int count = int(gc.params.y + 0.5);
  for (int k = 0; k < count; k++) {
    if (k == cube || !gc_surely_inside(k, p)) {
      continue;
    }
    float plane = abs(dot(gc_centre(k).xyz - p, w_hat));
    if (plane < best_dist) {
      best = k;
      best_dist = plane;
    }
  }
  return best;
}

/* geocube/model.py exit_search for one ray: returns the exit point; cube, normal, steps, premature out. */
vec3 gc_exit(vec3 origin, vec3 r, inout int cube, bool first_step, out vec3 normal, out int steps,
             out bool premature)
{
  float min_step = gc.sigma_s.w;
  int max_steps = int(gc.params.z + 0.5);
  vec3 p = origin;
  if (first_step) {
    p += r * max(gc_fetch(cube, origin - gc_centre(cube).xyz).w, min_step);
  }
  vec3 prev = origin;
  int prev_cube = cube;
  vec3 last_surface = origin;
  steps = 0;
  premature = true;
  vec3 point = origin;
  for (int i = 0; i < max_steps; i++) {
    steps += 1;
    vec4 o = gc_centre(cube);
    vec3 q = p - o.xyz;
    float l = length(q);
    float step = 0.0;
    if (l < o.w) {
      /* Sphere D: D S*(l / D, r . v). */
      step = o.w * s_star(l / o.w, dot(r, q / max(l, 1e-20)));
    }
    else {
      vec3 v = q / l;
      vec4 c = gc_fetch(cube, q);
      last_surface = o.xyz + v * c.x;
      if (l >= c.x) {
        int other = gc_switch(cube, p);
        if (other < 0) {
          /* Left the object between prev and p: bisection (geocube/model.py REFINE halvings). */
          vec3 a = prev;
          vec3 b = p;
          for (int k = 0; k < 6; k++) {
            vec3 m = 0.5 * (a + b);
            if (gc_inside(prev_cube, m)) {
              a = m;
            }
            else {
              b = m;
            }
          }
          point = 0.5 * (a + b);
          premature = false;
          break;
        }
        cube = other;
      }
      else {
        /* Chan & Wang Sec. 2.2: cone A (apex S, base O) and cone B (apex O, base on the tangent plane). */
        vec3 N = gc_normal(cube, q);
        float sA = c.x * cone_step(l / c.x, r, -v, -v, c.y);
        float sB = c.x * cone_step((c.x - l) / c.x, r, v, N, c.z);
        step = max(sA, sB);
      }
    }
    prev = p;
    prev_cube = cube;
    p += r * max(step, min_step);
  }
  if (premature) {
    point = last_surface;
  }
  cube = prev_cube;
  normal = gc_normal(prev_cube, point - gc_centre(prev_cube).xyz);
  return point;
}
