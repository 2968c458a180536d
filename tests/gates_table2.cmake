# Gate of Table 2 (single-camera tracking): Ours beats BA only, the middle camera alone is worse
# than the rig for the whole panorama, and absolute ceilings, on both quick-size scans (SO-1, SL-1).
panoscan_add_test(gate_table2_test SOURCES gate_table2_test.cpp DEPS panoscan_tables panoscan_core LABELS gate)
