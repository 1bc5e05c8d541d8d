// --shadows gpu: CPVS walked in a compute shader (cpvs_shadows.comp with the runtime's dag_walk.glsl.h and
// lookup_cell.glsl), K x K PCF, one 8 x 8 tile per work group. A second program also records each pair's voxel
// and verdict (FrameSettings::recordCells) for the GPU = CPU tests.
#include "libcpvs/gl/gl_program.h"
#include "libcpvs/preview/glsl_sources.h"
#include "libcpvs/preview/shadow_pass.h"

namespace cpvs {

namespace {

class CpvsGpuShadows final : public ShadowPass {
public:
  CpvsGpuShadows(const gl::Context& c, size_t lights) : counters_(GpuWorkCounters::forLookups(lights)) {
    const std::string counters = GpuWorkCounters::glsl(counters_);
    for (bool record : {false, true})
      (record ? recording_ : plain_) = gl::linkProgram(
          c, {{GL_COMPUTE_SHADER, computeSource({record ? "#define RECORD_CELLS\n" : "",
                                                 "layout(local_size_x = 8, local_size_y = 8) in;\n",
                                                 counters.c_str(), glsl::light_glsl_h, glsl::lookup_records_glsl,
                                                 glsl::scene_buffers_glsl, glsl::lookup_cell_glsl, glsl::dag_walk_glsl_h,
                                                 glsl::cpvs_shadows_comp})}},
          record ? "CPVS shadow (recording)" : "CPVS shadow");
  }

  bool run(ShadowPassFrame& p) override {
    const gl::Context& c = *p.resources.context;
    const gl::Functions& g = c.gl();
    Frame& f = p.frame;
    const GLuint program = p.settings.recordCells ? recording_ : plain_;
    GpuWorkCounters work(c, counters_);
    p.timed("shadows", [&] {
      g.UseProgram(program);
      p.bindSceneBuffers(program);
      if (p.cells) g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kCells, p.cells);
      work.bind();
      g.Uniform1i(g.GetUniformLocation(program, "pcfKernel"), p.settings.pcfKernel);
      g.Uniform1d(g.GetUniformLocation(program, "biasMargin"), p.settings.biasMargin);
      g.DispatchCompute(f.lists.tilesX, f.lists.tilesY, 1);
      g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    });
    gl::checkError(c, "running the CPVS shadow pass");
    const size_t pairSlots = size_t(f.lists.offsets.back()) * 64;
    f.visibility.resize(pairSlots);
    gl::readStorageBuffer(c, p.visibility, f.visibility.data(), pairSlots * 4);
    GpuWorkCounters::toFrame(work.read(), f);  // DAG node units and leaves
    if (p.cells) {
      f.cells.resize(pairSlots);
      gl::readStorageBuffer(c, p.cells, f.cells.data(), pairSlots * 16);
    }
    return true;
  }

private:
  uint32_t counters_ = 1;
  GLuint plain_ = 0, recording_ = 0;
};

}  // namespace

std::unique_ptr<ShadowPass> makeCpvsGpuShadows(RendererResources& resources) {
  resources.uploadDags();
  return std::make_unique<CpvsGpuShadows>(*resources.context, resources.lights.size());
}

}  // namespace cpvs
