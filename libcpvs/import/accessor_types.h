#pragma once
// glTF 2.0 accessor formats (glTF 2.0 specification, "Accessor Data Types"): the sizes and names of component
// types and element types, one table for the importer and the Draco decoder.
#include <cstddef>

namespace cpvs::gltf {

// The most elements an accessor (or a decoded compressed stream) may have: cpvs meshes index with uint32.
inline constexpr size_t kMaxElements = size_t(0xFFFFFFFFu);

// Bytes of one component: 1, 2 or 4 for the six component types glTF 2.0 allows (BYTE, UNSIGNED_BYTE, SHORT,
// UNSIGNED_SHORT, UNSIGNED_INT, FLOAT); 0 for any other value, INT and DOUBLE included (OpenGL has them,
// glTF accessors do not).
size_t componentSize(int componentType);
// Components of one element: SCALAR 1, VEC2 2, VEC3 3, VEC4 4, MAT2 4, MAT3 9, MAT4 16; 0 for anything else.
size_t componentCount(int type);
bool isMatrixType(int type);
// "FLOAT", "INT", ... and "unknown": for messages, also for values glTF does not allow.
const char* componentTypeName(int componentType);
const char* typeName(int type);

}  // namespace cpvs::gltf
