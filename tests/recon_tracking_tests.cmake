# Joint tracking (paper §4.1): front end, factor graph, ablations, bad input, on small simulated scans.
panoscan_add_test(recon_tracking_test
  SOURCES recon_tracking_test.cpp
  DEPS panoscan_recon_tracking panoscan_sim panoscan_scenes panoscan_eval nlohmann_json::nlohmann_json
  LABELS e2e)
# The named steps of the graph (tracking_graph.h) are internal to the library.
target_include_directories(recon_tracking_test PRIVATE ${CMAKE_SOURCE_DIR}/recon/tracking/src)
# The factors on their own: Jacobians against numeric differentiation, residuals against their definitions.
panoscan_add_test(recon_tracking_factors_test
  SOURCES recon_tracking_factors_test.cpp
  DEPS panoscan_core Ceres::ceres
  LABELS recon)
target_include_directories(recon_tracking_factors_test PRIVATE ${CMAKE_SOURCE_DIR}/recon/tracking/src)
# Band alignment across cameras (the front end's internal cross_camera.h) on synthetic views with known truth.
panoscan_add_test(recon_cross_camera_test
  SOURCES recon_cross_camera_test.cpp
  DEPS panoscan_recon_frontend
  LABELS recon)
target_include_directories(recon_cross_camera_test PRIVATE ${CMAKE_SOURCE_DIR}/recon/frontend/src)
# The shared ORB module: the matching rule and detection.
panoscan_add_test(recon_features_test
  SOURCES recon_features_test.cpp
  DEPS panoscan_recon_features
  LABELS recon)
# Handheld recordings: a simulated one-camera walk tracked without rotator assumptions (ba-only,
# single-camera), the rotator's modes refused, the program's track + eval traj.
panoscan_add_test(recon_handheld_test
  SOURCES recon_handheld_test.cpp
  DEPS panoscan_recon_tracking panoscan_sim panoscan_scenes panoscan_eval nlohmann_json::nlohmann_json
  LABELS e2e)
add_dependencies(recon_handheld_test panoscan)
# The depth odometry (beyond the paper) on depth images of planes with a known motion.
panoscan_add_test(recon_depth_odometry_test
  SOURCES recon_depth_odometry_test.cpp
  DEPS panoscan_recon_tracking panoscan_recon_frontend panoscan_core
  LABELS recon)
target_include_directories(recon_depth_odometry_test PRIVATE ${CMAKE_SOURCE_DIR}/recon/tracking/src)
