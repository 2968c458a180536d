# Joint tracking (paper §4.1, Table 6 / Fig. 8): front end per frame and optimisation per panorama.
add_executable(tracking_benchmark tracking_benchmark.cpp)
target_link_libraries(tracking_benchmark PRIVATE panoscan_recon_tracking panoscan_eval panoscan_sim panoscan_scenes benchmark::benchmark)
