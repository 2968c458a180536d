// The panoscan program on bad input: non-zero exit, a one-line reason naming the file and the
// field, and no partial output.
#include <array>
#include <cstdio>
#include <fstream>

#include <gtest/gtest.h>

#include "cli_util.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/process.h"
#include "panoscan/core/version.h"
#include "test_util.h"

namespace fs = std::filesystem;

namespace {

using panoscan::testutil::expect_failure_naming;
using panoscan::testutil::RunResult;
RunResult run(const std::string& arguments) { return panoscan::testutil::run_panoscan(arguments); }

std::size_t count_entries(const fs::path& dir) {
  std::size_t n = 0;
  for (auto it = fs::directory_iterator(dir); it != fs::directory_iterator(); ++it) ++n;
  return n;
}

}  // namespace

TEST(Cli, HelpOnEverySubcommand) {
  for (const std::string sub : {"", "sim", "demo", "scene", "scene export", "scene generate", "eval flat-pixels"}) {
    const RunResult r = run(sub + " --help");
    EXPECT_EQ(r.exit_code, 0) << sub;
    EXPECT_NE(r.output.find("Usage"), std::string::npos) << sub;
  }
}

TEST(Cli, VersionNamesTheSourceRevision) {
  const RunResult r = run("--version");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output, "panoscan " + panoscan::project_version() + " (" + panoscan::source_revision() + ")\n");
}

TEST(Cli, ReexecutesWithTheSettingsReadAtStartUpAndKeepsTheUsers) {
  // core/process.h: the program runs with OpenMP's passive wait and glibc's huge-page heap; the
  // debug log names what the running process got.
  const std::string tunables = panoscan::huge_page_heap_supported() ? "glibc.malloc.hugetlb=1" : "(unset)";
  RunResult r = panoscan::testutil::run_panoscan("-v scene list", "-u OMP_WAIT_POLICY -u GLIBC_TUNABLES");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("OMP_WAIT_POLICY=PASSIVE GLIBC_TUNABLES=" + tunables + "\n"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("could not re-execute"), std::string::npos) << r.output;
  // Other tunables are kept, the huge pages added to them.
  r = panoscan::testutil::run_panoscan("-v scene list",
                                       "OMP_WAIT_POLICY=ACTIVE GLIBC_TUNABLES=glibc.malloc.arena_max=4");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const std::string with_others = panoscan::huge_page_heap_supported()
                                      ? "glibc.malloc.arena_max=4:glibc.malloc.hugetlb=1"
                                      : "glibc.malloc.arena_max=4";
  EXPECT_NE(r.output.find("OMP_WAIT_POLICY=ACTIVE GLIBC_TUNABLES=" + with_others + "\n"), std::string::npos)
      << r.output;
  // A user's own hugetlb setting (here: off) is left alone.
  r = panoscan::testutil::run_panoscan("-v scene list", "GLIBC_TUNABLES=glibc.malloc.hugetlb=0");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("GLIBC_TUNABLES=glibc.malloc.hugetlb=0\n"), std::string::npos) << r.output;
}

TEST(Cli, TheProgramAloneReexecutesItselfWithTheSettings) {
  // app/launcher.cpp adds the settings before the program is loaded; panoscan-main run on its own
  // (under gdb, say) gets them by re-executing itself, as before the launcher.
  const std::string tunables = panoscan::huge_page_heap_supported() ? "glibc.malloc.hugetlb=1" : "(unset)";
  const RunResult r =
      panoscan::testutil::run_command("env -u OMP_WAIT_POLICY -u GLIBC_TUNABLES " + std::string(PANOSCAN_BINARY_DIR) +
                                      "/app/panoscan-main -v scene list");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("OMP_WAIT_POLICY=PASSIVE GLIBC_TUNABLES=" + tunables + "\n"), std::string::npos) << r.output;
}

TEST(Cli, TheLauncherFindsTheProgramThroughALinkAndSaysWhenItIsMissing) {
  panoscan::testutil::TempDir tmp("cli_launcher");
  const fs::path launcher = fs::path(PANOSCAN_BINARY_DIR) / "app" / "panoscan";
  // A symbolic link elsewhere (e.g. in ~/bin) runs the program beside the launcher it points to.
  fs::create_symlink(launcher, tmp / "panoscan");
  RunResult r = panoscan::testutil::run_command((tmp / "panoscan").string() + " --version");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output, "panoscan " + panoscan::project_version() + " (" + panoscan::source_revision() + ")\n");
  // A copy has no program beside it: one line naming the path it looked for, exit 2.
  fs::copy_file(launcher, tmp / "copy");
  fs::permissions(tmp / "copy", fs::perms::owner_exec, fs::perm_options::add);
  r = panoscan::testutil::run_command((tmp / "copy").string() + " --version");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(r.output, "panoscan: cannot run " + (tmp / "panoscan-main").string() + ": No such file or directory\n");
}

TEST(Cli, StartingLoadsNeitherOpen3dNorOpenCvsDecoders) {
  // Both are modules loaded on first use (recon/open3d, core/src/opencv_decoder.cpp): together they
  // were ~180 of the program's 211 shared libraries and most of its 0.3 s start. The loader's log
  // (LD_DEBUG=files) names every object it opens.
  const RunResult r = panoscan::testutil::run_command("env LD_DEBUG=files " + std::string(PANOSCAN_BINARY_DIR) +
                                                      "/app/panoscan --version");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("libopencv_core"), std::string::npos) << "the log names no libraries: " << r.output;
  for (const std::string library :
       {"libOpen3D", "libopencv_imgcodecs", "libgdal", "panoscan_open3d_module", "panoscan_opencv_decoder"})
    EXPECT_EQ(r.output.find(library), std::string::npos) << library << " is loaded at start-up";
}

TEST(Cli, BadInputExitsNonZeroNamingFileAndField) {
  panoscan::testutil::TempDir tmp("cli");
  const std::string out = (tmp / "scan").string();
  const std::string small = " --resolution 32x24 --every 300 --threads 1";

  expect_failure_naming(run("sim --scene " + (tmp / "missing.obj").string() + " --out " + out + small),
                        {"missing.obj"});

  { std::ofstream(tmp / "corrupt.obj") << "v 0 0 0\nv 1 0 0\nf 1 2 9\nthis is not an OBJ file\n"; }
  expect_failure_naming(run("sim --scene " + (tmp / "corrupt.obj").string() + " --out " + out + small),
                        {"corrupt.obj"});

  { std::ofstream(tmp / "negative.yaml") << "shutter:\n  fps: -30\n"; }
  expect_failure_naming(run("sim --config " + (tmp / "negative.yaml").string() + " --out " + out + small),
                        {"negative.yaml", "shutter.fps"});

  { std::ofstream(tmp / "unknown.yaml") << "noise:\n  presett: kinect\n"; }
  expect_failure_naming(run("sim --config " + (tmp / "unknown.yaml").string() + " --out " + out + small),
                        {"unknown.yaml", "noise.presett"});

  expect_failure_naming(run("sim --set output.every=0 --out " + out + small.substr(0, small.find(" --every"))),
                        {"output.every"});
  expect_failure_naming(run("sim --position 9 --out " + out + small), {"position"});
  expect_failure_naming(run("sim --noise loud --out " + out + small), {"noise.preset"});
  expect_failure_naming(run("sim --resolution big --out " + out + small.substr(small.find(" --every"))),
                        {"--resolution"});

  { std::ofstream(tmp / "a_file") << "x"; }
  expect_failure_naming(run("sim --out " + (tmp / "a_file" / "scan").string() + small), {"a_file"});

  // Every failure above left no output behind (only the inputs written by this test).
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(count_entries(tmp.path()), 4u);  // corrupt.obj, negative.yaml, unknown.yaml, a_file
}

TEST(Cli, ReconCommandsRejectBadInputNamingTheFileOrField) {
  panoscan::testutil::TempDir tmp("cli-recon");
  const std::string missing = (tmp / "no-such-scan").string();
  expect_failure_naming(run("recon track --scan " + missing + " --out " + (tmp / "t").string()), {"no-such-scan"});
  expect_failure_naming(run("recon panorama --scan " + missing + " --poses ground-truth --out " + (tmp / "p").string()),
                        {"no-such-scan"});
  expect_failure_naming(run("recon scene --scans " + missing + " --poses sideways --out " + (tmp / "s").string()),
                        {"--poses"});
  expect_failure_naming(run("recon panorama --scan " + missing + " --method blur --out " + (tmp / "p").string()),
                        {"panorama.method"});
  expect_failure_naming(
      run("recon scene --scans " + missing + " --set registration.method=icp-best --out " + (tmp / "s").string()),
      {"registration.method"});
  EXPECT_EQ(count_entries(tmp.path()), 0u);  // nothing written
}

TEST(Cli, SimWritesAScanAndRefusesToOverwriteIt) {
  panoscan::testutil::TempDir tmp("cli-sim");
  const std::string out = (tmp / "scan").string();
  const RunResult first = run("sim --scene living_room --position SL-2 --resolution 32x24 --every 300 --out " + out);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_TRUE(fs::exists(tmp / "scan" / "rig.json"));
  EXPECT_TRUE(fs::exists(tmp / "scan" / "groundtruth" / "mesh.ply"));
  const RunResult second = run("sim --scene living_room --position SL-2 --resolution 32x24 --every 300 --out " + out);
  expect_failure_naming(second, {out, "exists"});
  const RunResult third =
      run("sim --scene living_room --position SL-2 --resolution 32x24 --every 300 --overwrite --out " + out);
  EXPECT_EQ(third.exit_code, 0) << third.output;
}

TEST(Cli, TablesListsItsDriversAndRejectsBadNamesSizesAndNoise) {
  const RunResult list = run("tables list");
  EXPECT_EQ(list.exit_code, 0) << list.output;
  EXPECT_NE(list.output.find("table6"), std::string::npos) << list.output;

  panoscan::testutil::TempDir tmp("cli-tables");
  const std::string out = " --out " + (tmp / "out").string() + " --cache " + (tmp / "cache").string();
  expect_failure_naming(run("tables table99" + out), {"table99", "table6"});
  expect_failure_naming(run("tables table6 --size huge" + out), {"--size", "huge"});
  // The noise name is checked before anything is simulated or written.
  expect_failure_naming(run("tables table6 --noise loud" + out), {"noise.preset", "loud"});
  EXPECT_FALSE(fs::exists(tmp / "out" / "loud" / "table6" / "table6.md"));
}

// `recon track` refuses a trajectory that fails its self-check: exit code 2, one line naming the
// scan and the check, nothing written; --allow-unreliable writes it, marked.
TEST(Cli, ReconTrackRefusesAnUntrustworthyTrajectoryNamingTheScanAndTheCheck) {
  panoscan::testutil::TempDir tmp("cli-refuse");
  const std::string small = " --scene office --position SO-1 --resolution 320x240 --every 16 --threads 2";
  // A quarter of a revolution: tracking may be locally right, but a panoramic scan is one turn.
  const std::string quarter = (tmp / "quarter").string();
  ASSERT_EQ(run("sim" + small + " --set motion.turn_deg=90 --out " + quarter).exit_code, 0);
  const RunResult refused = run("recon track --scan " + quarter + " --out " + (tmp / "quarter-track").string());
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  expect_failure_naming(refused, {quarter, "not trustworthy", "turn:"});
  EXPECT_FALSE(fs::exists(tmp / "quarter-track"));
  const RunResult kept =
      run("recon track --allow-unreliable --scan " + quarter + " --out " + (tmp / "quarter-track").string());
  ASSERT_EQ(kept.exit_code, 0) << kept.output;
  EXPECT_NE(kept.output.find("UNRELIABLE"), std::string::npos) << kept.output;
  std::ifstream estimate(tmp / "quarter-track" / "rig_estimate.json");
  const std::string text((std::istreambuf_iterator<char>(estimate)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("tracked:full:unreliable"), std::string::npos);
  // ... and what consumes tracked poses refuses the same way.
  expect_failure_naming(
      run("recon panorama --scan " + quarter + " --poses tracked --height 64 --out " + (tmp / "quarter-pano").string()),
      {quarter, "not trustworthy", "turn:"});

  // A calibration 10 degrees off: the extrinsics the data ask for are far from rig.json's.
  const std::string miscalibrated = (tmp / "miscalibrated").string();
  ASSERT_EQ(run("sim" + small + " --set rig.calibration_error_deg=10 --out " + miscalibrated).exit_code, 0);
  const RunResult wrong = run("recon track --scan " + miscalibrated + " --out " + (tmp / "wrong-track").string());
  EXPECT_EQ(wrong.exit_code, 2) << wrong.output;
  expect_failure_naming(wrong, {miscalibrated, "not trustworthy", "extrinsics:", "calibration"});
  EXPECT_FALSE(fs::exists(tmp / "wrong-track"));
}

// scene.texture: icl (default), rich, plain for the built-in scenes; an unknown value or the key on
// a scene file fails naming the key; the densities export different materials.
TEST(Cli, SceneTextureDensityOption) {
  panoscan::testutil::TempDir tmp("cli-texture");
  const std::string small = " --resolution 32x24 --every 300 --threads 1";
  expect_failure_naming(run("sim --set scene.texture=fancy --out " + (tmp / "a").string() + small),
                        {"scene.texture", "fancy", "icl, rich, plain"});
  expect_failure_naming(run("scene export --scene office --set scene.texture=fancy --out " + (tmp / "b").string()),
                        {"scene.texture", "fancy"});
  expect_failure_naming(run("tables table6 --set scene.texture=fancy --out " + (tmp / "c").string()),
                        {"scene.texture", "fancy"});
  EXPECT_FALSE(fs::exists(tmp / "a"));
  EXPECT_FALSE(fs::exists(tmp / "b"));

  const RunResult plain =
      run("scene export --scene office --set scene.texture=plain --out " + (tmp / "plain").string());
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_EQ(count_entries(tmp / "plain" / "textures"), 0u);
  const RunResult icl = run("scene export --scene office --out " + (tmp / "icl").string());
  ASSERT_EQ(icl.exit_code, 0) << icl.output;
  std::ifstream mtl(tmp / "icl" / "office.mtl");
  const std::string materials((std::istreambuf_iterator<char>(mtl)), std::istreambuf_iterator<char>());
  EXPECT_NE(materials.find("newmtl wall_paint_light_grey"), std::string::npos);
  EXPECT_EQ(materials.find("brick_wall"), std::string::npos);

  // A scene file keeps its own materials: the key is refused rather than ignored.
  expect_failure_naming(run("sim --scene " + (tmp / "icl" / "office.obj").string() +
                            " --set scene.texture=rich --out " + (tmp / "d").string() + small),
                        {"office.obj", "scene.texture"});
  const RunResult rich = run("sim --scene office --set scene.texture=rich --out " + (tmp / "e").string() + small);
  EXPECT_EQ(rich.exit_code, 0) << rich.output;
}

TEST(Cli, EvalFlatPixels) {
  panoscan::testutil::TempDir tmp("cli-flat");
  expect_failure_naming(run("eval flat-pixels"), {"--panorama"});
  expect_failure_naming(run("eval flat-pixels --image " + (tmp / "none.png").string()), {"none.png"});
}

// scene generate writes an ordinary scene folder that sim accepts, the same bytes for the same seed.
TEST(Cli, SceneGenerateThenSim) {
  panoscan::testutil::TempDir tmp("cli-generate");
  expect_failure_naming(run("scene generate --kind kitchen --seed 1 --out " + (tmp / "k").string()),
                        {"--kind", "kitchen"});
  expect_failure_naming(run("scene generate --kind office --seed 1 --texture loud --out " + (tmp / "k").string()),
                        {"scene.texture", "loud"});
  EXPECT_FALSE(fs::exists(tmp / "k"));
  for (const std::string kind : {"office", "living_room"}) {
    const std::string dir = (tmp / kind).string();
    const RunResult generated = run("scene generate --kind " + kind + " --seed 3 --out " + dir);
    ASSERT_EQ(generated.exit_code, 0) << generated.output;
    const std::string obj = dir + "/" + kind + "_seed3.obj";
    EXPECT_TRUE(fs::exists(obj)) << generated.output;
    EXPECT_TRUE(fs::exists(dir + "/" + kind + "_seed3_groundtruth.ply"));
    EXPECT_TRUE(fs::exists(dir + "/" + kind + "_seed3.positions.json"));
    const RunResult sim = run("sim --scene " + obj + " --position 1 --resolution 32x24 --every 300 --threads 1 --out " +
                              (tmp / (kind + "-scan")).string());
    EXPECT_EQ(sim.exit_code, 0) << sim.output;
    EXPECT_TRUE(fs::exists(tmp / (kind + "-scan") / "rig.json"));
  }
  const RunResult again =
      run("scene generate --kind office --seed 3 --set scene.texture=icl --out " + (tmp / "again").string());
  ASSERT_EQ(again.exit_code, 0) << again.output;
  for (const std::string file : {"office_seed3.obj", "office_seed3.mtl", "office_seed3.positions.json"}) {
    std::ifstream a(tmp / "office" / file, std::ios::binary), b(tmp / "again" / file, std::ios::binary);
    const std::string bytes_a((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
    const std::string bytes_b((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
    EXPECT_FALSE(bytes_a.empty());
    EXPECT_TRUE(bytes_a == bytes_b) << file;
  }
}

// A room with no texture at all (scene.texture=plain: every surface one colour, ORB finds only the
// edges between objects): `recon track` either writes a correct trajectory (every camera's ATE
// under 10 mm) or refuses with exit code 2 naming the check, writing nothing. Never a wrong one.
TEST(Cli, ReconTrackOnAnUntexturedRoomIsCorrectOrRefused) {
  panoscan::testutil::TempDir tmp("cli-plain");
  const std::string scan = (tmp / "plain").string(), out = (tmp / "plain-track").string();
  ASSERT_EQ(run("sim --scene office --position SO-1 --resolution 320x240 --every 16 --threads 2 "
                "--set scene.texture=plain --out " +
                scan)
                .exit_code,
            0);
  const RunResult tracked = run("recon track --scan " + scan + " --out " + out + " --threads 2");
  std::printf("untextured office: %s", tracked.output.c_str());
  if (tracked.exit_code != 0) {
    EXPECT_EQ(tracked.exit_code, 2) << tracked.output;
    expect_failure_naming(tracked, {scan, "not trustworthy"});
    EXPECT_FALSE(fs::exists(out));
    return;
  }
  for (const char* camera : {"cam0", "cam1", "cam2"}) {
    const std::string report = (tmp / (std::string(camera) + ".json")).string();
    const RunResult ate = run("eval traj --gt " + scan + "/groundtruth/" + camera + ".txt --est " + out + "/" + camera +
                              ".txt --json " + report);
    ASSERT_EQ(ate.exit_code, 0) << ate.output;
    const double rmse_mm = panoscan::read_json_file(report).at("ate").at("rmse_mm").get<double>();
    std::printf("  %s ATE %.2f mm\n", camera, rmse_mm);
    EXPECT_LT(rmse_mm, 10.0) << camera << ": a wrong trajectory was written with exit code 0";
  }
  // recon track's default graph includes the depth odometry (beyond the paper), which holds the
  // frames of plain wall by their depth: nearly every consecutive pair of a camera enters it.
  const auto stats = panoscan::read_json_file(out + "/tracking_stats.json");
  const int pairs = stats.at("depth_odometry").at("pairs").get<int>();
  std::printf("  depth odometry: %d pairs, %d rejected\n", pairs, stats.at("depth_odometry").at("rejected").get<int>());
  EXPECT_GT(pairs, 0);
}
