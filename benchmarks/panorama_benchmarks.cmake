# Panorama construction (paper §4.2) and the TSDF baseline: time and peak memory per panorama.
add_executable(panorama_benchmark panorama_benchmark.cpp)
target_link_libraries(panorama_benchmark PRIVATE panoscan_recon_panorama panoscan_recon_open3d panoscan_sim panoscan_scenes panoscan_eval
  TBB::tbb benchmark::benchmark)

# Experiment drivers that live beside the panorama tests (lambda sweep, balance study):
# the same sources built with PANOSCAN_EXPERIMENTS, not registered with CTest.
#   build/benchmarks/panorama_experiments --gtest_filter='PanoramaExperiment*'
add_executable(panorama_experiments ${CMAKE_SOURCE_DIR}/tests/recon_panorama_test.cpp
                                    ${CMAKE_SOURCE_DIR}/tests/recon_panorama_baselines_test.cpp)
target_include_directories(panorama_experiments PRIVATE ${CMAKE_SOURCE_DIR}/recon/panorama/src)
target_compile_definitions(panorama_experiments PRIVATE PANOSCAN_EXPERIMENTS
  PANOSCAN_BINARY_DIR="${CMAKE_BINARY_DIR}" PANOSCAN_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
target_link_libraries(panorama_experiments PRIVATE panoscan_recon_panorama panoscan_recon_open3d panoscan_sim panoscan_scenes panoscan_eval
  TBB::tbb GTest::gtest_main GTest::gmock)
