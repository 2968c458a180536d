# Pre-stitched baselines of Table 1: grouping, the virtual camera, stitching accuracy (GT vs EX),
# Open3D odometry over the stitched sequence, bad input.
panoscan_add_test(recon_baselines_test SOURCES recon_baselines_test.cpp
  DEPS panoscan_recon_baselines panoscan_recon_panorama panoscan_sim panoscan_scenes panoscan_eval LABELS recon baselines)
# Open3D's OpenMP threads spin while idle unless told otherwise before the runtime starts (a
# setenv inside the program is too late: libgomp reads it when it is loaded).
set_tests_properties(recon_baselines_test PROPERTIES ENVIRONMENT "OMP_WAIT_POLICY=PASSIVE")
