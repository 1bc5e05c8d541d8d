// Shading: KHR_lights_punctual's model (point and spot: candela with inverse-square falloff and the range
// window; spot: the smooth cone; directional: lux), Lambert plus a Blinn-Phong highlight, each light scaled
// by its visibility (the shadow pass's or the CPU's / Embree's, uploaded). Linear radiance out, tone-mapped on
// the CPU. `stats`: per pixel the lights listed for its tile and how many of those that reach it shadow it.
layout(binding = 2) uniform sampler2D baseColors;
layout(std430, binding = 12) writeonly buffer Radiance { vec4 radiance[]; };  // rgb, w = covered
layout(std430, binding = 13) writeonly buffer PixelStats { uvec2 stats[]; };   // (listed, shadowed)
uniform vec3 eye;
uniform float specular;
void main() {
  uint tile = gl_WorkGroupID.y * uint(tileCount.x) + gl_WorkGroupID.x;
  uint local = gl_LocalInvocationID.y * 8u + gl_LocalInvocationID.x;
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= imageSize_.x || pixel.y >= imageSize_.y) return;
  uint index = uint(pixel.y * imageSize_.x + pixel.x);
  vec4 position = texelFetch(positions, pixel, 0);
  uint count = tileOffsets[tile + 1u] - tileOffsets[tile];
  if (position.w == 0.0) {
    radiance[index] = vec4(0.0);
    stats[index] = uvec2(count, 0u);
    return;
  }
  vec3 n = normalize(texelFetch(normals, pixel, 0).xyz);
  vec3 albedo = texelFetch(baseColors, pixel, 0).rgb;
  vec3 toEye = normalize(eye - position.xyz);
  vec3 sum = vec3(0.0);
  uint shadowed = 0u;
  for (uint slot = 0u; slot < count; ++slot) {
    gLight = tileLights[tileOffsets[tile] + slot];
    uint shape = cpvsLightShape();
    vec3 color = vec3(cpvsLightReal(CPVS_LIGHT_COLOR), cpvsLightReal(CPVS_LIGHT_COLOR + 1u),
                      cpvsLightReal(CPVS_LIGHT_COLOR + 2u)) * float(cpvsLightReal(CPVS_LIGHT_INTENSITY));
    vec3 direction = vec3(cpvsLightReal(CPVS_LIGHT_DIRECTION), cpvsLightReal(CPVS_LIGHT_DIRECTION + 1u),
                          cpvsLightReal(CPVS_LIGHT_DIRECTION + 2u));
    vec3 toLight;
    float attenuation = 1.0;
    if ((shape & CPVS_SHAPE_POSITION) == 0u) {
      toLight = -direction;
    } else {
      vec3 offset = vec3(dvec3(cpvsLightReal(CPVS_LIGHT_POSITION), cpvsLightReal(CPVS_LIGHT_POSITION + 1u),
                               cpvsLightReal(CPVS_LIGHT_POSITION + 2u)) - dvec3(position.xyz));
      float distance2 = max(dot(offset, offset), 1e-8);
      toLight = offset * inversesqrt(distance2);
      float range = float(cpvsLightReal(CPVS_LIGHT_RANGE));
      float window = 1.0;
      if (!isinf(range)) {
        float ratio = distance2 / (range * range);
        window = clamp(1.0 - ratio * ratio, 0.0, 1.0);
        window *= window;
      }
      attenuation = window / distance2;
      if ((shape & CPVS_SHAPE_CONE) != 0u) {
        float cosOuter = float(cpvsLightReal(CPVS_LIGHT_COS_OUTER)), cosInner = float(cpvsLightReal(CPVS_LIGHT_COS_INNER));
        float scale = 1.0 / max(0.001, cosInner - cosOuter);
        float t = clamp(dot(direction, -toLight) * scale - cosOuter * scale, 0.0, 1.0);
        attenuation *= t * t;
      }
    }
    float lambert = max(dot(n, toLight), 0.0);
    if (attenuation <= 0.0 || lambert <= 0.0) continue;
    float v = visibility[pairIndex(tile, slot, local)];
    if (v < 0.5) ++shadowed;
    vec3 halfway = normalize(toLight + toEye);
    float highlight = specular * pow(max(dot(n, halfway), 0.0), 64.0);
    sum += v * attenuation * lambert * color * (albedo / 3.14159265 + vec3(highlight));
  }
  radiance[index] = vec4(sum, 1.0);
  stats[index] = uvec2(count, shadowed);
}
