// Counts the texels still peeling (GL_SAMPLES_PASSED): peeling stops when none, or only a few, are left.
uniform sampler2D counts;
void main() {
  if (texelFetch(counts, ivec2(gl_FragCoord.xy), 0).r <= 0.0) discard;
}
