# Gate of the paper's Table 4 (registration cost functions on ground-truth-pose panoramas), quick size.
panoscan_add_test(gate_table4_test SOURCES gate_table4_test.cpp DEPS panoscan_tables panoscan_core LABELS gate)
