# The runtime's files, for this build and for any project that vendors them (docs/runtime.md).
get_filename_component(CPVS_RUNTIME_INCLUDE_DIR "${CMAKE_CURRENT_LIST_DIR}/../.." ABSOLUTE)
set(_cpvs_runtime_dir "${CPVS_RUNTIME_INCLUDE_DIR}/libcpvs/runtime")
set(CPVS_RUNTIME_SOURCES
  ${CPVS_RUNTIME_INCLUDE_DIR}/formats/cpvs/cpvs_reader.cpp
  ${_cpvs_runtime_dir}/batch_cells.cpp
  ${_cpvs_runtime_dir}/batch_cells_avx2.cpp
  ${_cpvs_runtime_dir}/batch_cells_avx512.cpp
  ${_cpvs_runtime_dir}/dag_walks_avx512.cpp
  ${_cpvs_runtime_dir}/light.cpp
  ${_cpvs_runtime_dir}/light_view.cpp
  ${_cpvs_runtime_dir}/outcome.cpp
  ${_cpvs_runtime_dir}/shadow_dag.cpp
  ${_cpvs_runtime_dir}/shadow_lookup.cpp
  ${_cpvs_runtime_dir}/view_mapping.cpp)

# No fused multiply-add where the source has a multiply and an add, in the files that map points to voxels:
# the scalar, AVX2 and AVX-512 paths (view_mapping.h) must round alike, and alike with the baker, whatever
# -march a build adds. GCC fuses by default where the target has FMA, clang within an expression.
function(cpvs_runtime_floating_point)
  set_source_files_properties(
    ${_cpvs_runtime_dir}/batch_cells.cpp
    ${_cpvs_runtime_dir}/batch_cells_avx2.cpp
    ${_cpvs_runtime_dir}/batch_cells_avx512.cpp
    ${_cpvs_runtime_dir}/light_view.cpp
    ${_cpvs_runtime_dir}/view_mapping.cpp
    ${_cpvs_runtime_dir}/shadow_lookup.cpp
    PROPERTIES COMPILE_OPTIONS -ffp-contract=off)
endfunction()
