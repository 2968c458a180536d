# Panorama construction (paper §4.2): warping, Eq. 5-7 solvers, variance, files, bad input; TSDF baseline.
panoscan_add_test(recon_panorama_test SOURCES recon_panorama_test.cpp
  DEPS panoscan_recon_panorama panoscan_sim panoscan_scenes panoscan_eval TBB::tbb LABELS recon panorama)
panoscan_add_test(recon_panorama_baselines_test SOURCES recon_panorama_baselines_test.cpp
  DEPS panoscan_recon_panorama panoscan_sim panoscan_scenes panoscan_eval LABELS recon panorama)
# The terms of Eq. 5-7 are internal to the library (recon/panorama/src/depth_terms.h).
target_include_directories(recon_panorama_test PRIVATE ${CMAKE_SOURCE_DIR}/recon/panorama/src)
# The solver's AVX kernels (depth_terms_avx.cpp) are tested against the scalar terms where the
# library has them.
get_target_property(panoscan_panorama_defs panoscan_recon_panorama COMPILE_DEFINITIONS)
if(panoscan_panorama_defs MATCHES "PANOSCAN_DEPTH_TERMS_AVX")
  target_compile_definitions(recon_panorama_test PRIVATE PANOSCAN_DEPTH_TERMS_AVX)
endif()
