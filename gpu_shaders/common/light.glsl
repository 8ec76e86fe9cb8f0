/* Emitter model of translucent_addon/core/lights.py (Cycles' units), for passes with a `light`
 * block. Returns the light's radiance factor at p: irradiance on a surface facing it
 * (directional) or intensity / d^2 with the spot and area lobes (point); to_light is set. */
float emitter_lobe(vec3 dir_from_light)
{
  float cos_axis = dot(dir_from_light, light.direction.xyz);
  float lobe = 1.0;
  if (light.cone.x >= -1.0) {
    lobe = (light.cone.y > 0.0) ? smoothstep(0.0, 1.0, (cos_axis - light.cone.x) / light.cone.y) :
                                  float(cos_axis > light.cone.x);
  }
  if (light.cone.z > 0.5) {
    lobe *= max(cos_axis, 0.0);
  }
  return lobe;
}

vec3 emitter_irradiance(vec3 p, out vec3 to_light)
{
  if (light.position_kind.w < 0.5) {
    to_light = -light.direction.xyz;
    return light.radiance.rgb;
  }
  vec3 d = light.position_kind.xyz - p;
  float dist = length(d);
  to_light = d / dist;
  return light.radiance.rgb * emitter_lobe(-to_light) / (dist * dist);
}
