# The runtime's files, for this build and for any project that vendors them (docs/runtime.md). Their include
# root also holds formats/cpvs/, the file's definition (headers only), which the runtime includes.
get_filename_component(CPVS_RUNTIME_INCLUDE_DIR "${CMAKE_CURRENT_LIST_DIR}/../.." ABSOLUTE)
set(_cpvs_runtime_dir "${CPVS_RUNTIME_INCLUDE_DIR}/libcpvs/runtime")
set(_cpvs_runtime_files batch_cells batch_cells_avx2 batch_cells_avx512 batch_cells_neon batch_lookup cpvs_reader
  dag_walks_avx2 dag_walks_avx512 byte_dag file_pool file_shadows gpu_records light light_view lookup_isa outcome
  pool_validation cpu_features read_only_file shadow_dag shadow_lookup shadowed_texels view_mapping)
list(TRANSFORM _cpvs_runtime_files PREPEND "${_cpvs_runtime_dir}/")
list(TRANSFORM _cpvs_runtime_files APPEND ".cpp")
set(CPVS_RUNTIME_SOURCES ${_cpvs_runtime_files})

# No fused multiply-add where the source has a multiply and an add, in the files that map points to voxels:
# the scalar, NEON, AVX2 and AVX-512 paths (view_mapping.h) must round alike, and alike with the baker, whatever
# -march a build adds. GCC fuses by default where the target has FMA, clang within an expression.
function(cpvs_runtime_floating_point)
  set(mapping_files batch_cells batch_cells_avx2 batch_cells_avx512 batch_cells_neon batch_lookup light light_view view_mapping shadow_lookup
    shadowed_texels)
  list(TRANSFORM mapping_files PREPEND "${_cpvs_runtime_dir}/")
  list(TRANSFORM mapping_files APPEND ".cpp")
  set_source_files_properties(${mapping_files}
    PROPERTIES COMPILE_OPTIONS -ffp-contract=off)
endfunction()
