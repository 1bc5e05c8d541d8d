// ManyPSMs' splats into the atlas (layer per vertex: GL_ARB_shader_viewport_layer_array), enabled by the program: every emitted
// (triangle, view) as three vertices pulled from the renderer's vertex buffer, or with POINTS every emitted
// (node, view) as one texel at its box's centre with the box's nearest depth. A view smaller than the layer is
// moved into its cell and clipped to it; a view as large as the layer keeps shadow_map_clip.glsl's bits, so it
// equals the per-light map texel for texel.
layout(std430, binding = 31) readonly buffer Vertices { float vertices[]; };  // renderer_resources.cpp's layout
uniform uint layerSize;
uniform uint vertexFloats;
out float vDepth;
out vec2 vMaskUv;
flat out int vMask;
flat out int vCasts;
flat out int vLinearDepth;
flat out float vNearDepth, vSliceScale, vMapSize;
out float gl_ClipDistance[4];
void main() {
#ifdef POINTS
  uvec2 item = psmPoints[gl_VertexID];
  PsmNode node = psmNodes[item.x];
  vec3 world = 0.5 * (node.lo.xyz + node.hi.xyz);
  vMaskUv = vec2(0.0);
  vMask = -1;
  vCasts = 1;
#else
  uvec2 item = psmTriangles[gl_VertexID / 3];
  uint at = (3u * item.x + uint(gl_VertexID % 3)) * vertexFloats;
  vec3 world = vec3(vertices[at], vertices[at + 1u], vertices[at + 2u]);
  vMaskUv = vec2(vertices[at + 13u], vertices[at + 14u]);
  vMask = int(vertices[at + 15u]);
  vCasts = int(vertices[at + 16u]);
#endif
  PsmView view = psmViews[item.y];
  vec4 p = shadowMapClip(world, view.viewFromWorld, view.lateral, view.depth.x != 0.0, vDepth);
#ifdef POINTS
  // The box's nearest depth: a splat shadows at least what the node's nearest point would.
  mat3 m = mat3(view.viewFromWorld);
  vec3 e = 0.5 * (node.hi.xyz - node.lo.xyz);
  vDepth -= dot(abs(vec3(m[0].z, m[1].z, m[2].z)), e);
  gl_PointSize = 1.0;
#endif
  vLinearDepth = int(view.depth.y);
  vNearDepth = view.depth.z;
  vSliceScale = view.depth.w;
  vMapSize = float(view.cell.w);
  gl_Layer = int(view.cell.x);
  if (view.cell.w == layerSize) {
    for (int i = 0; i < 4; ++i) gl_ClipDistance[i] = 1.0;
  } else {
    gl_ClipDistance[0] = p.w + p.x;
    gl_ClipDistance[1] = p.w - p.x;
    gl_ClipDistance[2] = p.w + p.y;
    gl_ClipDistance[3] = p.w - p.y;
    // NDC [-1, 1] of the view onto its cell [origin, origin + res) of the layer's [0, layerSize).
    float scale = float(view.cell.w) / float(layerSize);
    vec2 offset = (2.0 * vec2(view.cell.yz) + float(view.cell.w)) / float(layerSize) - 1.0;
    p.xy = p.xy * scale + p.w * offset;
  }
  gl_Position = p;
}
