# Gate of Table 1 (whole-panorama quality): ours (Surfels-4m) beats the EX pre-stitched baseline,
# and absolute ceilings on our rows at the quick size (one scan, SO-1).
panoscan_add_test(gate_table1_test SOURCES gate_table1_test.cpp DEPS panoscan_tables panoscan_core LABELS gate)
# Open3D's OpenMP threads spin while idle unless told before the runtime starts (measured: the
# odometry 16.5 s passive against 122 s spinning on the shared 2-core machine).
set_tests_properties(gate_table1_test PROPERTIES ENVIRONMENT "OMP_WAIT_POLICY=PASSIVE")
