// Peels the closed faces of one side (the draw culls the other) beyond that side's cursor, for active texels.
uniform sampler2D cursors;   // RG32F: front cursor, back cursor (stored depth of the last consumed event)
uniform sampler2D counts;    // R32F: > 0 while active
uniform int side;            // 0 = front faces, 1 = back faces
layout(location = 0) out float one;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  if (texelFetch(counts, p, 0).r <= 0.0) discard;
  float z = storedDepth();
  vec2 c = texelFetch(cursors, p, 0).rg;
  if (z <= (side == 0 ? c.x : c.y)) discard;
  gl_FragDepth = z;
  one = 1.0;
}
