#ifndef CPVS_RUNTIME_LIGHT_GLSL_H
#define CPVS_RUNTIME_LIGHT_GLSL_H
// The light type codes of light.h's LightType for two compilers: included by C++ (light.cpp checks every
// code against the enum at compile time) and pasted before lookup_records.glsl into every cpvs-view shader that
// reads a light record (the type word, CPVS_LIGHT_TYPE). Shaders compare with these names, never with numbers,
// so a new light type is one line here and one in LightType. Comments stay ASCII (GLSL).
#define CPVS_LIGHT_DIRECTIONAL 0u
#define CPVS_LIGHT_SPOT 1u
#define CPVS_LIGHT_POINT 2u
#define CPVS_LIGHT_TYPE_COUNT 3u

#endif  // CPVS_RUNTIME_LIGHT_GLSL_H
