// The alpha-test scene: small and fixed, so that the shadows of alpha-tested and blended casters can be
// worked out by hand (docs/scenegen.md gives the analytic answer).
//
// y up. A white ground quad (y = 0, x and z in [-4, 4]) under three horizontal cards at y = 1, all lit by a
// sun shining straight down:
//   * MaskCard   x in [-3.5, -1.5], z in [-1, 1]: alphaMode MASK (cutoff 0.5) with an 8 x 8 checker whose
//                texels (i, j) are opaque where i + j is even and clear where it is odd;
//   * GlassPane  x in [-1, 1], z in [-1, 1]: alphaMode BLEND, alpha 0.1, no texture;
//   * OpaqueCard x in [1.5, 3.5], z in [-1, 1]: alphaMode OPAQUE with the same checker (alpha ignored).
// Every node is at identity except the sun's rotation.
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "generators.h"
#include "png_writer.h"

namespace cpvs::scenegen {
namespace {

// A horizontal quad x0..x1, z0..z1 at height y facing +y (counter-clockwise seen from above), with
// TEXCOORD_0 = ((x - u0) / uScale, (z - v0) / vScale) when `uv` is set.
GenMesh horizontalQuad(const char* name, double x0, double x1, double z0, double z1, double y, int material,
                       bool uv, double u0 = 0.0, double v0 = 0.0, double uvScale = 1.0) {
  GenMesh m;
  m.name = name;
  m.material = material;
  // Up order: (x1, z0), (x0, z0), (x0, z1), (x1, z1); the fan (0, 1, 2), (0, 2, 3) faces +y.
  const double corners[4][2] = {{x1, z0}, {x0, z0}, {x0, z1}, {x1, z1}};
  for (const auto& c : corners) {
    m.positions.emplace_back(static_cast<float>(c[0]), static_cast<float>(y), static_cast<float>(c[1]));
    if (uv)
      m.texcoords.emplace_back(static_cast<float>((c[0] - u0) / uvScale), static_cast<float>((c[1] - v0) / uvScale));
  }
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

}  // namespace

GenScene generateAlphaTest() {
  GenScene scene;

  // The 8 x 8 checker: texel (column i, row j; row 0 is the image's top, where v = 0) is green with
  // alpha 255 where i + j is even, alpha 0 where it is odd.
  std::vector<std::uint8_t> rgba(8 * 8 * 4);
  for (int j = 0; j < 8; ++j) {
    for (int i = 0; i < 8; ++i) {
      std::uint8_t* t = &rgba[static_cast<std::size_t>(4 * (8 * j + i))];
      t[0] = 51;   // 0.2 * 255
      t[1] = 153;  // 0.6 * 255
      t[2] = 51;
      t[3] = (i + j) % 2 == 0 ? 255 : 0;
    }
  }
  GenTexture checker;
  checker.name = "Checker";
  checker.png = encodePngRgba(8, 8, rgba);
  checker.magFilter = kFilterNearest;
  checker.minFilter = kFilterNearest;
  checker.wrapS = kWrapClampToEdge;
  checker.wrapT = kWrapClampToEdge;
  scene.textures.push_back(std::move(checker));

  GenMaterial ground;
  ground.name = "Ground";
  scene.materials.push_back(ground);
  scene.materials.push_back(alphaTestedMaterial("LeafMask", 0));
  scene.materials.push_back(blendedMaterial("ClearGlass", {0.8, 0.9, 1.0, 0.1}));
  GenMaterial opaque;
  opaque.name = "CheckerOpaque";
  opaque.baseColorTexture = 0;
  opaque.doubleSided = true;
  scene.materials.push_back(opaque);

  scene.meshes.push_back(horizontalQuad("Ground", -4.0, 4.0, -4.0, 4.0, 0.0, 0, false));
  scene.meshes.push_back(horizontalQuad("MaskCard", -3.5, -1.5, -1.0, 1.0, 1.0, 1, true, -3.5, -1.0, 2.0));
  scene.meshes.push_back(horizontalQuad("GlassPane", -1.0, 1.0, -1.0, 1.0, 1.0, 2, false));
  scene.meshes.push_back(horizontalQuad("OpaqueCard", 1.5, 3.5, -1.0, 1.0, 1.0, 3, true, 1.5, -1.0, 2.0));
  for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
    GenNode n;
    n.name = scene.meshes[i].name;
    n.mesh = static_cast<int>(i);
    scene.nodes.push_back(n);
  }

  GenLight sun;
  sun.name = "Sun";
  sun.intensity = 1.0;
  scene.lights.push_back(sun);
  GenNode sunNode;
  sunNode.name = "Sun";
  sunNode.light = 0;
  const double h = std::sqrt(0.5);  // a quarter turn about -X: local -Z straight down
  sunNode.rotation = Quat{-h, 0.0, 0.0, h};
  scene.nodes.push_back(sunNode);
  return scene;
}

}  // namespace cpvs::scenegen
