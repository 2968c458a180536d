# Panorama construction (paper §4.2): warping, Eq. 5-7 solvers, variance, files, bad input; TSDF baseline.
panoscan_add_test(recon_panorama_test SOURCES recon_panorama_test.cpp
  DEPS panoscan_recon_panorama panoscan_sim panoscan_scenes panoscan_eval TBB::tbb LABELS recon panorama)
panoscan_add_test(recon_panorama_baselines_test SOURCES recon_panorama_baselines_test.cpp
  DEPS panoscan_recon_panorama panoscan_sim panoscan_scenes panoscan_eval LABELS recon panorama)
# The terms of Eq. 5-7 are internal to the library (recon/panorama/src/depth_terms.h).
target_include_directories(recon_panorama_test PRIVATE ${CMAKE_SOURCE_DIR}/recon/panorama/src)
