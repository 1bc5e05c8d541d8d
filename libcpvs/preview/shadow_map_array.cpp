#include "libcpvs/preview/shadow_map_array.h"

#include <cmath>

#include "libcpvs/gl/gl_program.h"
#include "libcpvs/preview/glsl_sources.h"

namespace cpvs {

void ShadowMapArray::ensure(const gl::Context& c, uint32_t size, uint32_t layers) {
  const gl::Functions& g = c.gl();
  layers = std::max(1u, layers);
  if (texture_ && size_ == size && layers_ >= layers) return;
  if (texture_) g.DeleteTextures(1, &texture_);
  if (!framebuffer_) g.GenFramebuffers(1, &framebuffer_);
  g.GenTextures(1, &texture_);
  g.BindTexture(GL_TEXTURE_2D_ARRAY, texture_);
  g.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  g.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  g.TexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_DEPTH_COMPONENT32F, GLsizei(size), GLsizei(size), GLsizei(layers), 0,
               GL_DEPTH_COMPONENT, GL_FLOAT, nullptr);
  gl::checkError(c, "allocating " + std::to_string(layers) + " shadow-map layers of " + std::to_string(size) + "^2");
  size_ = size;
  layers_ = layers;
}

std::vector<uint16_t> ShadowMapArray::read(const gl::Context& c, const std::vector<MapPlace>& places) const {
  const gl::Functions& g = c.gl();
  size_t total = 0;
  for (const MapPlace& p : places) total += size_t(p.size) * p.size;
  std::vector<uint16_t> texels;
  texels.reserve(total);
  std::vector<float> depth;
  g.BindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  g.PixelStorei(GL_PACK_ALIGNMENT, 4);
  for (const MapPlace& p : places) {
    depth.resize(size_t(p.size) * p.size);
    g.FramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, texture_, 0, GLint(p.layer));
    g.ReadPixels(GLint(p.x), GLint(p.y), GLsizei(p.size), GLsizei(p.size), GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
    for (float d : depth) texels.push_back(uint16_t(std::lround(double(d) * 65536.0)));
  }
  gl::checkError(c, "reading back the shadow maps");
  return texels;
}

MapRecordBuffers uploadMapRecords(const gl::Context& c, const GpuSceneRecords& r, FrameBuffers& buffers) {
  MapRecordBuffers out;
  out.lightReals = buffers.add(gl::createStorageBuffer(c, r.lightReals.data(), r.lightReals.size() * 8));
  out.lightWords = buffers.add(gl::createStorageBuffer(c, r.lightWords.data(), r.lightWords.size() * 4));
  out.viewReals = buffers.add(gl::createStorageBuffer(c, r.viewReals.data(), r.viewReals.size() * 8));
  out.viewWords = buffers.add(gl::createStorageBuffer(c, r.viewWords.data(), r.viewWords.size() * 4));
  return out;
}

MapLookupProgram linkMapLookupProgram(const gl::Context& c, size_t lights) {
  MapLookupProgram out;
  out.counters = GpuWorkCounters::forLookups(lights);
  const std::string counters = GpuWorkCounters::glsl(out.counters);
  out.program = gl::linkProgram(
      c, {{GL_COMPUTE_SHADER, computeSource({"layout(local_size_x = 8, local_size_y = 8) in;\n", counters.c_str(),
                                             glsl::light_glsl_h, glsl::lookup_records_glsl, glsl::scene_buffers_glsl,
                                             glsl::lookup_cell_glsl, glsl::shadow_map_lookups_comp})}},
      "shadow-map lookup");
  return out;
}

void lookUpMaps(ShadowPassFrame& p, const MapLookupProgram& lookups, const ShadowMapArray& maps,
                const MapRecordBuffers& records) {
  RendererResources& r = p.resources;
  const gl::Functions& g = r.gl();
  Frame& f = p.frame;
  const GLuint program = lookups.program;
  GpuWorkCounters work(*r.context, lookups.counters);
  p.timed("shadows", [&] {
    g.UseProgram(program);
    g.Uniform2i(g.GetUniformLocation(program, "imageSize_"), GLint(f.width), GLint(f.height));
    g.Uniform2i(g.GetUniformLocation(program, "tileCount"), GLint(f.lists.tilesX), GLint(f.lists.tilesY));
    g.Uniform1i(g.GetUniformLocation(program, "pcfKernel"), p.settings.pcfKernel);
    g.Uniform1d(g.GetUniformLocation(program, "biasMargin"), p.settings.biasMargin);
    g.ActiveTexture(GL_TEXTURE0);
    g.BindTexture(GL_TEXTURE_2D, r.targets[0]);
    g.ActiveTexture(GL_TEXTURE1);
    g.BindTexture(GL_TEXTURE_2D, r.targets[1]);
    g.ActiveTexture(GL_TEXTURE3);
    g.BindTexture(GL_TEXTURE_2D_ARRAY, maps.texture());
    for (auto [index, buffer] : {std::pair{binding::kLightReals, records.lightReals}, {binding::kLightWords, records.lightWords},
                                   {binding::kTileOffsets, p.offsets}, {binding::kTileLights, p.lists}, {binding::kViewReals, records.viewReals},
                                   {binding::kViewWords, records.viewWords}, {binding::kDagNodes, r.dagNodes},
                                   {binding::kDagLeaves, r.dagLeaves}, {binding::kVisibility, p.visibility}})
      g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, index, buffer);
    work.bind();
    g.DispatchCompute(f.lists.tilesX, f.lists.tilesY, 1);
    g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  });
  gl::checkError(*r.context, "looking up the shadow maps");
  f.visibility.resize(size_t(f.lists.offsets.back()) * 64);
  gl::readStorageBuffer(*r.context, p.visibility, f.visibility.data(), f.visibility.size() * 4);
  GpuWorkCounters::toFrame(work.read(), f);
}

}  // namespace cpvs
