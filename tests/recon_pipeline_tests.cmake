panoscan_add_test(recon_stage2_test SOURCES recon_stage2_test.cpp
  DEPS panoscan_recon_pipeline panoscan_sim panoscan_scenes panoscan_eval nlohmann_json::nlohmann_json LABELS e2e)
# Its command tests run the panoscan program.
if(TARGET panoscan)
  add_dependencies(recon_stage2_test panoscan)
endif()
# recon register on point-cloud files: the library and the program.
panoscan_add_test(recon_cloud_registration_test SOURCES recon_cloud_registration_test.cpp
  DEPS panoscan_recon_pipeline panoscan_sim panoscan_scenes nlohmann_json::nlohmann_json)
if(TARGET panoscan)
  add_dependencies(recon_cloud_registration_test panoscan)
endif()
