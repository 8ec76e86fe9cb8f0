/* Functions shared by the passes (prepended to each pass source). */
#define PI 3.14159265358979

/* An object's tag (its object block's shading.x, and the id channel of IMAGE_SPACE's samples and G-buffer): its
 * number among the frame's subsurface objects times 64 plus its material slot (image_space/model.py object_tag),
 * 0 for other surfaces. Its material slot, or -1 for those. */
int material_slot(float tag)
{
  return (tag < 0.5) ? -1 : int(tag + 0.5) % 64;
}

/* Unpolarised Fresnel reflectance entering a dielectric of relative index eta. */
float fresnel_dielectric(float cos_i, float eta)
{
  cos_i = clamp(cos_i, 0.0, 1.0);
  float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0) {
    return 1.0;
  }
  float cos_t = sqrt(1.0 - sin2_t);
  float r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  float r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return 0.5 * (r_s * r_s + r_p * r_p);
}

/* Unit direction from a surface point toward the eye: the camera's position (perspective) or its
 * backward axis (orthographic, camera_position.w = 1); FrameData's camera fields. */
vec3 direction_to_eye(vec4 camera_position, vec4 camera_forward, vec3 p)
{
  return (camera_position.w > 0.5) ? -camera_forward.xyz : normalize(camera_position.xyz - p);
}

/* Distance from the eye to p: along the view axis for an orthographic camera (camera_position.w = 1),
 * from the camera's position otherwise; FrameData's camera fields. */
float eye_distance(vec4 camera_position, vec4 camera_forward, vec3 p)
{
  return (camera_position.w > 0.5) ? dot(p - camera_position.xyz, camera_forward.xyz) :
                                     length(p - camera_position.xyz);
}

int cube_face(vec3 d)
{
  vec3 a = abs(d);
  if (a.x >= a.y && a.x >= a.z) {
    return d.x > 0.0 ? 0 : 1;
  }
  if (a.y >= a.z) {
    return d.y > 0.0 ? 2 : 3;
  }
  return d.z > 0.0 ? 4 : 5;
}

/* Smooth partition of the profile: 0 below rho, 1 above 2 rho (physics/lut.py partition). */
float partition_weight(float r, float rho)
{
  float x = clamp((r - rho) / rho, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

/* The near field stands for the tangent disk at x_o: a sample off that plane (the far side of a
 * thin part) is not in it and keeps its whole share. h: its height over the plane, in r's units
 * (physics/lut.py partition_off_plane). */
float partition_weight_off_plane(float r, float rho, float h)
{
  float s = 1.0 - smoothstep(0.5, 0.8, h / max(r, 1e-12));
  return 1.0 - (1.0 - partition_weight(r, rho)) * s;
}

/* An n x 1 table's rgb at u in [0, 1] (texel k at u = k / (n - 1)), read linearly; one texel: its value. */
vec3 table_lerp(sampler2D table, float u)
{
  int n = textureSize(table, 0).x;
  float x = clamp(u, 0.0, 1.0) * float(n - 1);
  int k = min(int(floor(x)), max(n - 2, 0));
  return mix(texelFetch(table, ivec2(k, 0), 0).rgb, texelFetch(table, ivec2(min(k + 1, n - 1), 0), 0).rgb,
             x - float(k));
}

/* An n x 1 table of cosines' rgb at mu (texel k at mu = (k + 0.5) / n), read linearly and clamped to its end
 * texels (physics/angular_law.lookup); one texel: its value. */
vec3 cosine_lerp(sampler2D table, float mu)
{
  int n = textureSize(table, 0).x;
  float u = clamp(mu * float(n) - 0.5, 0.0, float(n - 1));
  int k = int(floor(u));
  return mix(texelFetch(table, ivec2(k, 0), 0).rgb, texelFetch(table, ivec2(min(k + 1, n - 1), 0), 0).rgb,
             u - float(k));
}

#ifdef GPU_FRAGMENT_SHADER
/* Whether this fragment sees the outside of its triangle: gl_FrontFacing under the object's own winding.
 * A mirrored object (a negative scale, a negative determinant: the object block's shading.y = 1) turns
 * every triangle's winding on screen, which drew it dark or not at all. */
bool facing_out(vec4 shading)
{
  return gl_FrontFacing != (shading.y > 0.5);
}
#endif
