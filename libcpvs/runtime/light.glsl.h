#ifndef CPVS_RUNTIME_LIGHT_GLSL_H
#define CPVS_RUNTIME_LIGHT_GLSL_H
// The light model (light.h) for two compilers: included by C++ (light.cpp checks the codes against the enum at
// compile time, tests/light_test.cpp the shape bits against the predicates) and pasted before lookup_records.glsl into every cpvs-view shader that
// reads a light record. Shaders branch on a light's shape bits (the record's CPVS_LIGHT_SHAPE word, written by
// shapeBits), never on its type, so a light type that answers light.h's predicates needs no shader of its own.
// Comments stay ASCII (GLSL).

// LightType's codes, as the file and the record's CPVS_LIGHT_TYPE word hold them.
#define CPVS_LIGHT_DIRECTIONAL 0u
#define CPVS_LIGHT_SPOT 1u
#define CPVS_LIGHT_POINT 2u
#define CPVS_LIGHT_TYPE_COUNT 3u

// Shape bits: hasPosition (else a direction only, everywhere), hasCone (the influence is a cone as well as a
// range), hasCubeFaces (six views, one per cube face; else one view).
#define CPVS_SHAPE_POSITION 1u
#define CPVS_SHAPE_CONE 2u
#define CPVS_SHAPE_CUBE_FACES 4u

#endif  // CPVS_RUNTIME_LIGHT_GLSL_H
