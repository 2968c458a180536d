// Tests of Config: YAML/JSON loading, dotted keys, overrides, type and range checks, and the
// rejection of unknown keys. Every error test checks that the message names where the value
// came from (file or command line) and the key.

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// A fresh directory per test, removed afterwards.
class ConfigFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    static std::atomic<int> counter{0};
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("panoscan_config_test_" + std::string(info->name()) + "_" +
                                        std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  fs::path write(const std::string& name, const std::string& text) {
    const fs::path path = dir_ / name;
    std::ofstream(path) << text;
    return path;
  }
  fs::path dir_;
};

using testutil::error_of;

const char* const kNestedYaml =
    "noise:\n"
    "  preset: handa\n"
    "  sigma: 0.5\n"
    "  enabled: true\n"
    "render:\n"
    "  every_nth: 3\n"
    "  seed: 18446744073709551615\n"
    "rig:\n"
    "  offset: [0.1, -0.2, 0.3]\n";

TEST(Config, EmptyConfigReturnsDefaults) {
  Config config;
  EXPECT_EQ(config.origin(), "<defaults>");
  EXPECT_DOUBLE_EQ(config.get_double("noise.sigma", 0.25, 0.0, 1.0), 0.25);
  EXPECT_EQ(config.get_int("render.every_nth", 1, 1, 90), 1);
  EXPECT_EQ(config.get_u64("seed", 42u), 42u);
  EXPECT_TRUE(config.get_bool("noise.enabled", true));
  EXPECT_EQ(config.get_string("noise.preset", "handa", {"handa", "none"}), "handa");
  EXPECT_EQ(config.get_doubles("rig.offset", {1.0, 2.0}, 2), (std::vector<double>{1.0, 2.0}));
  EXPECT_FALSE(config.has("noise.sigma"));
  EXPECT_NO_THROW(config.check_all_used());
}

TEST(Config, EmptyFileIsAnEmptyConfig) {
  Config config = Config::from_string("# only a comment\n", "empty.yaml");
  EXPECT_EQ(config.origin(), "empty.yaml");
  EXPECT_EQ(config.get_int("a.b", 7, 0, 10), 7);
  EXPECT_NO_THROW(config.check_all_used());
}

TEST(Config, NestedKeysAreReadWithDottedPaths) {
  Config config = Config::from_string(kNestedYaml, "nested.yaml");
  EXPECT_TRUE(config.has("noise"));
  EXPECT_TRUE(config.has("noise.preset"));
  EXPECT_FALSE(config.has("noise.missing"));
  EXPECT_FALSE(config.has("noise.preset.deeper"));  // a scalar has no children
  EXPECT_EQ(config.get_string("noise.preset", "none"), "handa");
  EXPECT_DOUBLE_EQ(config.get_double("noise.sigma", 0.0, 0.0, 1.0), 0.5);
  EXPECT_TRUE(config.get_bool("noise.enabled", false));
  EXPECT_EQ(config.get_int("render.every_nth", 1, 1, 90), 3);
  EXPECT_EQ(config.get_u64("render.seed", 0), 18446744073709551615ull);
  EXPECT_EQ(config.get_doubles("rig.offset", {}, 3), (std::vector<double>{0.1, -0.2, 0.3}));
  EXPECT_NO_THROW(config.check_all_used());
}

TEST(Config, BooleanSpellings) {
  Config config = Config::from_string("a: yes\nb: off\nc: False\nd: ON\n", "bools.yaml");
  EXPECT_TRUE(config.get_bool("a", false));
  EXPECT_FALSE(config.get_bool("b", true));
  EXPECT_FALSE(config.get_bool("c", true));
  EXPECT_TRUE(config.get_bool("d", false));
}

TEST(Config, OverridesReplaceAndCreateNestedKeys) {
  Config config = Config::from_string(kNestedYaml, "nested.yaml");
  config.apply_override("noise.sigma=0.75");
  config.apply_override("noise.preset = none");  // spaces around '=' and the value are ignored
  config.apply_override("tracking.window.size=12");
  config.apply_override("rig.offset=[1, 2, 3]");
  config.apply_override("output.name=");
  EXPECT_EQ(config.origin(), "nested.yaml + command line");
  EXPECT_DOUBLE_EQ(config.get_double("noise.sigma", 0.0, 0.0, 1.0), 0.75);
  EXPECT_EQ(config.get_string("noise.preset", "handa"), "none");
  EXPECT_EQ(config.get_int("tracking.window.size", 0, 0, 100), 12);
  EXPECT_EQ(config.get_doubles("rig.offset", {}, 3), (std::vector<double>{1.0, 2.0, 3.0}));
  EXPECT_EQ(config.get_string("output.name", "default"), "");
  // Keys of the file that were not overridden keep their values.
  EXPECT_EQ(config.get_int("render.every_nth", 1, 1, 90), 3);
  EXPECT_TRUE(config.has("tracking.window"));
}

TEST(Config, SetUsesYamlValues) {
  Config config;
  config.set("a.b", "3");
  config.set("a.c", "'quoted text'");
  EXPECT_EQ(config.get_int("a.b", 0, 0, 10), 3);
  EXPECT_EQ(config.get_string("a.c", ""), "quoted text");
  EXPECT_NO_THROW(config.check_all_used());
}

TEST(Config, MalformedOverridesAreRejected) {
  Config config = Config::from_string(kNestedYaml, "nested.yaml");
  std::string message = error_of([&] { config.apply_override("noise.sigma"); });
  EXPECT_THAT(message, HasSubstr("noise.sigma"));
  EXPECT_THAT(message, HasSubstr("key=value"));
  EXPECT_THAT(message, HasSubstr("command line"));

  message = error_of([&] { config.apply_override("=3"); });
  EXPECT_THAT(message, HasSubstr("'=3'"));
  message = error_of([&] { config.apply_override("a..b=3"); });
  EXPECT_THAT(message, HasSubstr("a..b=3"));

  // An unterminated flow sequence is a YAML syntax error in the override's value.
  message = error_of([&] { config.apply_override("rig.offset=[1, 2"); });
  EXPECT_THAT(message, HasSubstr("rig.offset=[1, 2"));
  EXPECT_THAT(message, HasSubstr("syntax error"));

  // A key below a scalar cannot be created.
  message = error_of([&] { config.apply_override("noise.preset.name=x"); });
  EXPECT_THAT(message, HasSubstr("nested.yaml"));
  EXPECT_THAT(message, HasSubstr("noise.preset"));
}

TEST(Config, TypeErrorsNameFileKeyAndValue) {
  Config config = Config::from_string(
      "noise:\n  sigma: abc\ncount: 3.5\nflag: maybe\nquoted: \"3\"\nlist: [1, 2]\nseed: -1\nname: [a]\n",
      "types.yaml");
  std::string message = error_of([&] { config.get_double("noise.sigma", 0.0, 0.0, 1.0); });
  EXPECT_THAT(message, HasSubstr("types.yaml"));
  EXPECT_THAT(message, HasSubstr("noise.sigma"));
  EXPECT_THAT(message, HasSubstr("'abc'"));
  EXPECT_THAT(message, HasSubstr("number"));

  message = error_of([&] { config.get_int("count", 0, 0, 10); });
  EXPECT_THAT(message, HasSubstr("types.yaml: count"));
  EXPECT_THAT(message, HasSubstr("'3.5'"));
  EXPECT_THAT(message, HasSubstr("integer"));

  message = error_of([&] { config.get_bool("flag", false); });
  EXPECT_THAT(message, HasSubstr("types.yaml: flag"));
  EXPECT_THAT(message, HasSubstr("'maybe'"));

  // A quoted "3" is a string, not a number.
  message = error_of([&] { config.get_int("quoted", 0, 0, 10); });
  EXPECT_THAT(message, HasSubstr("types.yaml: quoted"));
  EXPECT_THAT(message, HasSubstr("quoted string"));

  message = error_of([&] { config.get_double("list", 0.0, 0.0, 1.0); });
  EXPECT_THAT(message, HasSubstr("types.yaml: list"));
  EXPECT_THAT(message, HasSubstr("list of 2"));

  message = error_of([&] { config.get_u64("seed", 0); });
  EXPECT_THAT(message, HasSubstr("types.yaml: seed"));
  EXPECT_THAT(message, HasSubstr("'-1'"));

  message = error_of([&] { config.get_string("name", ""); });
  EXPECT_THAT(message, HasSubstr("types.yaml: name"));

  // A key below a scalar: the scalar is named.
  message = error_of([&] { config.get_double("count.sub", 0.0, 0.0, 1.0); });
  EXPECT_THAT(message, HasSubstr("types.yaml: count"));
  EXPECT_THAT(message, HasSubstr("expected a map"));
}

TEST(Config, ListErrorsNameTheSizeOrTheItem) {
  Config config = Config::from_string("a: [1, 2]\nb: [1, x, 3]\nc: 4\n", "lists.yaml");
  std::string message = error_of([&] { config.get_doubles("a", {}, 3); });
  EXPECT_THAT(message, HasSubstr("lists.yaml: a"));
  EXPECT_THAT(message, HasSubstr("expected 3 numbers, found 2"));
  message = error_of([&] { config.get_doubles("b", {}, 3); });
  EXPECT_THAT(message, HasSubstr("lists.yaml: b"));
  EXPECT_THAT(message, HasSubstr("item 1"));
  message = error_of([&] { config.get_doubles("c", {}, 1); });
  EXPECT_THAT(message, HasSubstr("lists.yaml: c"));
  // expected_size 0 accepts any length.
  EXPECT_EQ(config.get_doubles("a", {}, 0).size(), 2u);
}

TEST(Config, RangeErrorsNameFileKeyValueAndRange) {
  Config config = Config::from_string("noise:\n  sigma: 1.5\nframes: 0\nnan_value: .nan\n", "range.yaml");
  std::string message = error_of([&] { config.get_double("noise.sigma", 0.0, 0.0, 1.0); });
  EXPECT_THAT(message, HasSubstr("range.yaml"));
  EXPECT_THAT(message, HasSubstr("noise.sigma"));
  EXPECT_THAT(message, HasSubstr("1.5"));
  EXPECT_THAT(message, HasSubstr("[0, 1]"));

  message = error_of([&] { config.get_int("frames", 1, 1, 90); });
  EXPECT_THAT(message, HasSubstr("range.yaml: frames"));
  EXPECT_THAT(message, HasSubstr("[1, 90]"));

  // NaN passes no range check.
  message = error_of([&] { config.get_double("nan_value", 0.0, -1e300, 1e300); });
  EXPECT_THAT(message, HasSubstr("range.yaml: nan_value"));

  // The bounds themselves are inside the range.
  Config edges = Config::from_string("lo: 0\nhi: 1\n", "edges.yaml");
  EXPECT_DOUBLE_EQ(edges.get_double("lo", 0.5, 0.0, 1.0), 0.0);
  EXPECT_DOUBLE_EQ(edges.get_double("hi", 0.5, 0.0, 1.0), 1.0);
}

TEST(Config, OverrideErrorsNameTheCommandLine) {
  Config config = Config::from_string(kNestedYaml, "nested.yaml");
  config.apply_override("noise.sigma=7");
  const std::string message = error_of([&] { config.get_double("noise.sigma", 0.0, 0.0, 1.0); });
  EXPECT_THAT(message, HasSubstr("command line"));
  EXPECT_THAT(message, HasSubstr("noise.sigma"));
  EXPECT_THAT(message, HasSubstr("7"));
}

TEST(Config, AllowedStrings) {
  Config config = Config::from_string("noise:\n  preset: kinekt\n", "allowed.yaml");
  const std::string message = error_of([&] {
    config.get_string("noise.preset", "handa", {"handa", "handa-icl", "kinect", "none"});
  });
  EXPECT_THAT(message, HasSubstr("allowed.yaml: noise.preset"));
  EXPECT_THAT(message, HasSubstr("'kinekt'"));
  EXPECT_THAT(message, HasSubstr("handa, handa-icl, kinect, none"));

  config.apply_override("noise.preset=kinect");
  EXPECT_EQ(config.get_string("noise.preset", "handa", {"handa", "handa-icl", "kinect", "none"}), "kinect");
}

TEST(Config, UnknownKeysAreRejectedByName) {
  Config config = Config::from_string("noise:\n  presett: handa\n  sigma: 0.5\n", "typo.yaml");
  config.get_string("noise.preset", "handa");
  config.get_double("noise.sigma", 0.0, 0.0, 1.0);
  const std::string message = error_of([&] { config.check_all_used(); });
  EXPECT_THAT(message, HasSubstr("typo.yaml"));
  EXPECT_THAT(message, HasSubstr("noise.presett"));
  EXPECT_THAT(message, HasSubstr("unknown key"));
}

TEST(Config, UnknownTopLevelSectionIsNamedAtItsTop) {
  Config config = Config::from_string("noize:\n  preset: handa\nnoise:\n  preset: none\n", "typo.yaml");
  config.get_string("noise.preset", "handa");
  const std::string message = error_of([&] { config.check_all_used(); });
  EXPECT_THAT(message, HasSubstr("typo.yaml: noize: unknown key"));
}

TEST(Config, UnknownOverrideKeyNamesTheCommandLine) {
  Config config = Config::from_string(kNestedYaml, "nested.yaml");
  config.apply_override("noise.sigmaa=0.1");
  config.get_string("noise.preset", "");
  config.get_double("noise.sigma", 0.0, 0.0, 1.0);
  config.get_bool("noise.enabled", false);
  config.get_int("render.every_nth", 1, 1, 90);
  config.get_u64("render.seed", 0);
  config.get_doubles("rig.offset", {}, 3);
  const std::string message = error_of([&] { config.check_all_used(); });
  EXPECT_THAT(message, HasSubstr("command line"));
  EXPECT_THAT(message, HasSubstr("noise.sigmaa"));
}

TEST(Config, KeysAskedForButAbsentAreNotUnknown) {
  // A getter asking for a key that is absent must not make check_all_used fail later.
  Config config = Config::from_string("a: 1\n", "a.yaml");
  config.get_int("a", 0, 0, 10);
  config.get_int("b.c", 0, 0, 10);
  EXPECT_NO_THROW(config.check_all_used());
}

TEST_F(ConfigFileTest, YamlSyntaxErrorNamesFileLineAndColumn) {
  const fs::path path = write("broken.yaml", "noise:\n  preset: handa\n  sigma: [0.5, 1\nrender: 3\n");
  const std::string message = error_of([&] { Config::load_file(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  EXPECT_THAT(message, HasSubstr("syntax error"));
  EXPECT_THAT(message, HasSubstr("line "));
  EXPECT_THAT(message, HasSubstr("column "));
}

TEST_F(ConfigFileTest, MissingFileIsNamed) {
  const fs::path path = dir_ / "does_not_exist.yaml";
  const std::string message = error_of([&] { Config::load_file(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  EXPECT_THAT(message, HasSubstr("not found"));
}

TEST_F(ConfigFileTest, DirectoryIsNotAConfigFile) {
  const std::string message = error_of([&] { Config::load_file(dir_); });
  EXPECT_THAT(message, HasSubstr(dir_.string()));
}

TEST_F(ConfigFileTest, TopLevelMustBeAMap) {
  const fs::path path = write("list.yaml", "- a\n- b\n");
  std::string message = error_of([&] { Config::load_file(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  EXPECT_THAT(message, HasSubstr("top level"));
  message = error_of([&] { Config::from_string("just text", "scalar.yaml"); });
  EXPECT_THAT(message, HasSubstr("scalar.yaml"));
}

TEST_F(ConfigFileTest, DuplicateKeysAreRejected) {
  const fs::path path = write("dup.yaml", "noise:\n  sigma: 0.1\n  sigma: 0.2\n");
  const std::string message = error_of([&] { Config::load_file(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  EXPECT_THAT(message, HasSubstr("noise.sigma"));
  EXPECT_THAT(message, HasSubstr("twice"));
}

TEST_F(ConfigFileTest, JsonFilesAreRead) {
  const fs::path path = write("config.json",
                              "{\n  \"noise\": {\"preset\": \"kinect\", \"sigma\": 0.5, \"enabled\": false},\n"
                              "  \"render\": {\"every_nth\": 4},\n  \"rig\": {\"offset\": [1.5, 2, -3e-2]}\n}\n");
  Config config = Config::load_file(path);
  EXPECT_EQ(config.origin(), path.string());
  EXPECT_EQ(config.get_string("noise.preset", "handa", {"handa", "kinect"}), "kinect");
  EXPECT_DOUBLE_EQ(config.get_double("noise.sigma", 0.0, 0.0, 1.0), 0.5);
  EXPECT_FALSE(config.get_bool("noise.enabled", true));
  EXPECT_EQ(config.get_int("render.every_nth", 1, 1, 90), 4);
  EXPECT_EQ(config.get_doubles("rig.offset", {}, 3), (std::vector<double>{1.5, 2.0, -0.03}));
  EXPECT_NO_THROW(config.check_all_used());

  // A JSON string where a number is expected is a type error, as in YAML.
  const fs::path bad = write("bad.json", "{\"render\": {\"every_nth\": \"4\"}}\n");
  Config bad_config = Config::load_file(bad);
  const std::string message = error_of([&] { bad_config.get_int("render.every_nth", 1, 1, 90); });
  EXPECT_THAT(message, HasSubstr(bad.string()));
  EXPECT_THAT(message, HasSubstr("render.every_nth"));
}

TEST_F(ConfigFileTest, JsonSyntaxErrorIsReported) {
  const fs::path path = write("broken.json", "{\"noise\": {\"preset\": \"handa\"}\n");  // unclosed
  const std::string message = error_of([&] { Config::load_file(path); });
  EXPECT_THAT(message, HasSubstr(path.string()));
  EXPECT_THAT(message, HasSubstr("line "));
}

TEST(Config, MovedConfigKeepsItsState) {
  Config config = Config::from_string("a: 2\n", "move.yaml");
  Config moved(std::move(config));
  EXPECT_EQ(moved.origin(), "move.yaml");
  EXPECT_EQ(moved.get_int("a", 0, 0, 10), 2);
  Config assigned;
  assigned = std::move(moved);
  EXPECT_EQ(assigned.get_int("a", 0, 0, 10), 2);
  EXPECT_NO_THROW(assigned.check_all_used());
}

}  // namespace
}  // namespace panoscan
