// `panoscan report` checked in a real browser: the page made from the committed quick records plus a
// tiny panorama and track folder is opened in headless Chromium (Debian's chromium), and the page's
// own check script (every <img> loaded with naturalWidth > 0, the tables counted) is read back from
// the dumped DOM; a copy with one corrupted image must be caught by the same check. A screenshot is
// saved in the build tree. Skipped when /usr/bin/chromium is absent (PANOSCAN_CHROMIUM overrides the
// path). Every Chromium runs in its own process group with a private profile folder and a time
// limit; the group is killed afterwards, and the test checks that no process of that profile is left.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "cli_util.h"
#include "test_util.h"

namespace fs = std::filesystem;
using panoscan::testutil::run_panoscan;
using panoscan::testutil::RunResult;
using panoscan::testutil::TempDir;

namespace {

std::string chromium_path() {
  const char* custom = std::getenv("PANOSCAN_CHROMIUM");
  return custom && *custom ? custom : "/usr/bin/chromium";
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The pids whose command line names `needle` (the private profile folder), zombies aside.
std::vector<pid_t> processes_naming(const std::string& needle) {
  std::vector<pid_t> found;
  std::error_code ec;
  for (fs::directory_iterator it("/proc", ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::string cmdline = read_file(it->path() / "cmdline");
    for (char& c : cmdline)
      if (c == '\0') c = ' ';
    if (cmdline.find(needle) != std::string::npos && pid_t(std::stoi(name)) != ::getpid())
      found.push_back(pid_t(std::stoi(name)));
  }
  return found;
}

struct BrowserRun {
  int exit_code = -1;
  bool timed_out = false;
  std::string out, log;
};

// Runs Chromium headless on `url` with `extra` flags: its own process group, a profile folder under
// `work`, stdout and stderr into files there, killed (the whole group) after `timeout_s` seconds or
// when it exits. Leftover processes of the profile are killed by pid and reported as a failure.
BrowserRun run_chromium(const fs::path& work, const std::vector<std::string>& extra, const std::string& url,
                        int timeout_s = 90) {
  static int counter = 0;
  const fs::path profile = work / ("chromium-profile-" + std::to_string(counter++));
  const fs::path out_file = profile.string() + ".out", log_file = profile.string() + ".log";
  fs::create_directories(profile);
  std::vector<std::string> args = {chromium_path(),
                                   "--headless",
                                   "--no-sandbox",  // needed as root
                                   "--disable-gpu",
                                   "--no-first-run",
                                   "--no-default-browser-check",
                                   "--disable-extensions",
                                   "--disable-background-networking",
                                   "--disable-component-update",
                                   "--disable-sync",
                                   "--disable-breakpad",
                                   "--disable-crash-reporter",
                                   "--user-data-dir=" + profile.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  args.push_back(url);
  BrowserRun run;
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setpgid(0, 0);
    const int out = ::open(out_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int log = ::open(log_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int none = ::open("/dev/null", O_RDONLY);
    if (out < 0 || log < 0 || none < 0) ::_exit(126);
    ::dup2(none, 0);
    ::dup2(out, 1);
    ::dup2(log, 2);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  if (pid < 0) {
    ADD_FAILURE() << "fork failed";
    return run;
  }
  ::setpgid(pid, pid);  // also here, so that the group exists before any kill below
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  int status = 0;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) {
      run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      break;
    }
    if (std::chrono::steady_clock::now() > deadline) {
      run.timed_out = true;
      ::kill(-pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ::kill(-pid, SIGKILL);  // whatever of its group is still there
  // Helpers that left the group: found by the profile folder in their command line, killed by pid.
  std::vector<pid_t> left;
  for (int attempt = 0; attempt < 20; ++attempt) {
    left = processes_naming(profile.string());
    if (left.empty()) break;
    if (attempt >= 10)
      for (pid_t p : left) ::kill(p, SIGKILL);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(left.empty()) << left.size() << " chromium process(es) of " << profile << " outlived the run (killed)";
  run.out = read_file(out_file);
  run.log = read_file(log_file);
  return run;
}

struct PageCheck {
  bool found = false;
  int images = -1, loaded = -1, tables = -1, plots = -1;
};

// The page's own check, written into <pre id="report-check"> on window load.
PageCheck page_check(const std::string& dom) {
  PageCheck c;
  std::smatch m;
  if (std::regex_search(dom, m,
                        std::regex("<pre id=\"report-check\">images=(\\d+) loaded=(\\d+) tables=(\\d+) plots=(\\d+)"))) {
    c.found = true;
    c.images = std::stoi(m[1]);
    c.loaded = std::stoi(m[2]);
    c.tables = std::stoi(m[3]);
    c.plots = std::stoi(m[4]);
  }
  return c;
}

PageCheck load_in_browser(const fs::path& work, const fs::path& page) {
  const BrowserRun run =
      run_chromium(work, {"--virtual-time-budget=5000", "--dump-dom"}, "file://" + fs::absolute(page).string());
  EXPECT_FALSE(run.timed_out) << "chromium --dump-dom timed out; its log:\n" << run.log;
  EXPECT_EQ(run.exit_code, 0) << run.log;
  const PageCheck check = page_check(run.out);
  EXPECT_TRUE(check.found) << "no page check in the DOM of " << page << " (" << run.out.size()
                           << " bytes); chromium's log:\n"
                           << run.log;
  return check;
}

}  // namespace

TEST(ReportBrowser, EveryImageLoadsAndTheTablesArePresent) {
  if (!fs::exists(chromium_path()))
    GTEST_SKIP() << "no browser at " << chromium_path() << " (Debian: apt-get install chromium): report not checked";
  const auto start = std::chrono::steady_clock::now();
  TempDir tmp("report-browser");
  const fs::path out_dir = fs::path(PANOSCAN_BINARY_DIR) / "tests" / "report_browser";
  fs::create_directories(out_dir);
  const fs::path report = out_dir / "report.html", screenshot = out_dir / "report.png";
  fs::remove(report);
  fs::remove(screenshot);

  // A tiny scan, its panorama and its track (the page must show them, not judge them).
  const std::string scan = (tmp / "scan").string();
  RunResult r = run_panoscan("-q sim --scene office --resolution 128x96 --every 48 --threads 2 --out " + scan);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = run_panoscan("-q recon panorama --scan " + scan + " --poses ground-truth --height 64 --threads 2 --out " +
                   (tmp / "pano").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = run_panoscan("-q recon track --scan " + scan + " --allow-unreliable --threads 2 --out " + (tmp / "track").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  fs::create_directories(tmp / "stray");
  std::ofstream(tmp / "stray" / "notes.txt") << "not a result\n";

  const std::string records = std::string(PANOSCAN_SOURCE_DIR) + "/benchmarks/results/quick/handa";
  r = run_panoscan("report --results " + records + " " + (tmp / "pano").string() + " " + (tmp / "track").string() + " " +
                   (tmp / "stray").string() + " --out " + report.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.output, m, std::regex("(\\d+) images, (\\d+) tables, (\\d+) plots, 1 not recognised")))
      << r.output;
  const int written_images = std::stoi(m[1]), written_tables = std::stoi(m[2]), written_plots = std::stoi(m[3]);
  EXPECT_GE(written_images, 5);   // fig8.png, the panorama's colour, depth, variance and flags
  EXPECT_GE(written_tables, 30);  // the seven records' tables and each section's key-value table
  EXPECT_GE(written_plots, 1);    // the trajectory

  // The page as the browser sees it.
  const PageCheck check = load_in_browser(tmp.path(), report);
  EXPECT_EQ(check.images, written_images);
  EXPECT_EQ(check.loaded, check.images) << "an image did not load";
  EXPECT_EQ(check.tables, written_tables);
  EXPECT_EQ(check.plots, written_plots);

  // The same check must catch a broken image: one data URI corrupted in a copy.
  std::string html = read_file(report);
  const std::string png = "data:image/png;base64,iVBORw0KGgo";
  const auto at = html.find(png);
  ASSERT_NE(at, std::string::npos);
  html.replace(at, png.size(), "data:image/png;base64,AAAAAAAAAAAA");
  const fs::path broken = tmp / "broken.html";
  std::ofstream(broken, std::ios::binary) << html;
  const PageCheck broken_check = load_in_browser(tmp.path(), broken);
  EXPECT_EQ(broken_check.images, written_images);
  EXPECT_EQ(broken_check.loaded, written_images - 1) << "the page check did not notice a broken image";

  // A screenshot to look at.
  const BrowserRun shot = run_chromium(tmp.path(),
                                       {"--hide-scrollbars", "--virtual-time-budget=5000", "--window-size=1280,2000",
                                        "--screenshot=" + screenshot.string()},
                                       "file://" + report.string());
  EXPECT_FALSE(shot.timed_out) << shot.log;
  ASSERT_TRUE(fs::exists(screenshot)) << shot.log;
  EXPECT_GT(fs::file_size(screenshot), 20000u);

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "report: " << report.string() << " (" << fs::file_size(report) / 1000 << " kB)\n"
            << "browser: images=" << check.images << " loaded=" << check.loaded << " tables=" << check.tables
            << " plots=" << check.plots << "; broken copy: loaded=" << broken_check.loaded << " of "
            << broken_check.images << "\nscreenshot: " << screenshot.string() << "\n"
            << "time: " << seconds << " s\n";
}
