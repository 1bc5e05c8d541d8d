#include "libcpvs/preview/shadow_pass.h"

namespace cpvs {

std::vector<PairsOfLight> pairsByLight(const Frame& f, size_t lightCount) {
  std::vector<PairsOfLight> byLight(lightCount);
  f.forEachPair([&](uint32_t, uint32_t, size_t i, uint32_t light, size_t pair) {
    byLight[light].pairs.push_back(pair);
    byLight[light].points.push_back({glm::dvec3(glm::vec3(f.positions[i])), glm::dvec3(glm::vec3(f.normals[i]))});
  });
  return byLight;
}

const std::vector<PairsOfLight>& ShadowPassFrame::pairsByLight() {
  if (!pairs_) pairs_ = cpvs::pairsByLight(frame, resources.lights.size());
  return *pairs_;
}

void ShadowPassFrame::bindSceneBuffers(GLuint program) const {
  const gl::Functions& g = resources.gl();
  g.Uniform2i(g.GetUniformLocation(program, "imageSize_"), GLint(frame.width), GLint(frame.height));
  g.Uniform2i(g.GetUniformLocation(program, "tileCount"), GLint(frame.lists.tilesX), GLint(frame.lists.tilesY));
  g.Uniform1i(g.GetUniformLocation(program, "tiles"), GLint(frame.lists.tiles()));
  for (GLuint unit = 0; unit < 3; ++unit) {
    g.ActiveTexture(GL_TEXTURE0 + unit);
    g.BindTexture(GL_TEXTURE_2D, resources.targets[unit]);
  }
  const RendererResources& r = resources;
  for (auto [index, buffer] : {std::pair{binding::kLightReals, r.lightReals}, {binding::kLightWords, r.lightWords},
                                 {binding::kTileOffsets, offsets}, {binding::kTileLights, lists}, {binding::kViewReals, r.viewReals},
                                 {binding::kViewWords, r.viewWords}, {binding::kDagNodes, r.dagNodes}, {binding::kDagLeaves, r.dagLeaves},
                                 {binding::kVisibility, visibility}})
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, index, buffer);
}

}  // namespace cpvs
