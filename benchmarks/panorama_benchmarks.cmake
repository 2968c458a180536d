# Panorama construction (paper §4.2) and the TSDF baseline: time and peak memory per panorama.
add_executable(panorama_benchmark panorama_benchmark.cpp)
target_link_libraries(panorama_benchmark PRIVATE panoscan_recon_panorama panoscan_sim panoscan_scenes panoscan_eval
  TBB::tbb benchmark::benchmark)
