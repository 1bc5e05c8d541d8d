#version 330 core
// Geometry vertices carry window positions computed on the CPU (snapped to 1/256 texel, exact up to the
// region's integer offset, so every region rasterises a triangle identically) and, flat, the triangle's depth
// as an affine function of the texel coordinates around an integer reference texel.
layout(location = 0) in vec4 clipPosition;
layout(location = 1) in vec3 plane;     // q0, dq/du, dq/dv
layout(location = 2) in ivec2 origin;   // reference texel (u0, v0), view texel coordinates
layout(location = 3) in vec2 range;     // q of the triangle lies in [range.x, range.y]
layout(location = 4) in int mask;       // alpha-tested: the mask's index, else -1
layout(location = 5) in vec3 maskU;     // mask coordinates (U, V) / W, affine around the reference texel
layout(location = 6) in vec3 maskV;
layout(location = 7) in vec3 maskW;
flat out vec3 vPlane;
flat out ivec2 vOrigin;
flat out vec2 vRange;
flat out int vMask;
flat out vec3 vMaskU, vMaskV, vMaskW;
void main() {
  gl_Position = clipPosition;
  vPlane = plane;
  vOrigin = origin;
  vRange = range;
  vMask = mask;
  vMaskU = maskU;
  vMaskV = maskV;
  vMaskW = maskW;
}
