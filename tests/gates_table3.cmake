# Gate of the paper's Table 3 (frame integration on ground-truth poses), quick size.
panoscan_add_test(gate_table3_test SOURCES gate_table3_test.cpp DEPS panoscan_tables panoscan_core LABELS gate)
