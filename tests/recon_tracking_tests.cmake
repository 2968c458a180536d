# Joint tracking (paper §4.1): front end, factor graph, ablations, bad input, on small simulated scans.
panoscan_add_test(recon_tracking_test
  SOURCES recon_tracking_test.cpp
  DEPS panoscan_recon_tracking panoscan_sim panoscan_scenes panoscan_eval
  LABELS e2e)
