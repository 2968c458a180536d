# Gate of the paper's Table 5 (align only / + average / + MAP on ground-truth-pose panoramas), quick size.
panoscan_add_test(gate_table5_test SOURCES gate_table5_test.cpp DEPS panoscan_tables panoscan_core nlohmann_json::nlohmann_json LABELS gate)
