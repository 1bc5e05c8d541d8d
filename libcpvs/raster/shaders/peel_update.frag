// Lockstep peeling (Kampe et al. 2015, section 3.3; docs/references.md): every iteration consumes the next front layer
// and the next back layer.
// With fronts F1 < F2 < ... (F1 = the enter surface; coincident fronts count once, which can only make the
// exit earlier) and backs B1 <= B2 <= ... (coincident backs counted by multiplicity), the ray leaves the union
// of closed solids at the first Bj with Bj <= F(j+1): up to that back only j fronts were crossed. The state
// keeps nf = nb + 1, so the front peeled in iteration j is F(j+1) and the back is Bj. A back layer of
// multiplicity > 1 that is not an exit at its first entry is taken as the exit (its later entries would need
// fronts not yet peeled): earlier than the truth at worst, so never wrong.
uniform sampler2D cursors;
uniform sampler2D counts;
uniform sampler2D frontDepth;
uniform sampler2D backDepth;
uniform sampler2D backCount;
uniform int lastIteration;
layout(location = 0) out vec2 cursor;
layout(location = 1) out float count;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec2 c = texelFetch(cursors, p, 0).rg;
  float n = texelFetch(counts, p, 0).r;
  if (n > 0.0) {
    float f = texelFetch(frontDepth, p, 0).r;
    float b = texelFetch(backDepth, p, 0).r;
    bool hasF = f < 1.0, hasB = b < 1.0;
    if (!hasB) {
      n = kStuck;   // inside, and no closed back face before the far plane: the exit lies beyond it
    } else if (!hasF || b <= f || texelFetch(backCount, p, 0).r > 1.5) {
      c.y = b;      // exit (ties: back first, an earlier exit is the safe side)
      n = 0.0;
    } else {
      c = vec2(f, b);   // still inside after b: the exit lies beyond it
      if (lastIteration != 0) n = kCapped;
    }
  }
  cursor = c;
  count = n;
}
