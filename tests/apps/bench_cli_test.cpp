// `mctstereo bench` run as a user would: lists of sizes, ranges, threads and backends, the JSON
// report (records, per-stage times, settings, memory), and bad lists.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "mctstereo/mctstereo.hpp"

#include "cli_test_util.hpp"

namespace {

using mctstereo::test::kData;
using mctstereo::test::kProgram;
using mctstereo::test::read_text;
using mctstereo::test::Result;
using mctstereo::test::run_shell;
using mctstereo::test::shell_quoted;

namespace fs = std::filesystem;

// Just enough JSON to read the report back: every value kind, no escapes beyond \" \\ \/ \n \t.
// (A member is a struct declared ahead rather than a std::pair, which needs JsonValue complete
// where Clang instantiates it.)
struct JsonMember;
struct JsonValue {
  enum Kind { Null, Bool, Number, String, Array, Object } kind = Null;
  bool boolean = false;
  double number = 0;
  std::string text;
  std::vector<JsonValue> items;
  std::vector<JsonMember> members;

  bool has(const std::string& key) const;
  const JsonValue& operator[](const std::string& key) const;
};
struct JsonMember {
  std::string first;
  JsonValue second;
};

bool JsonValue::has(const std::string& key) const {
  return std::any_of(members.begin(), members.end(), [&](const JsonMember& m) { return m.first == key; });
}
const JsonValue& JsonValue::operator[](const std::string& key) const {
  for (const JsonMember& m : members)
    if (m.first == key) return m.second;
  throw std::out_of_range("no member '" + key + "'");
}

class JsonReader {
 public:
  explicit JsonReader(const std::string& text) : s_(text) {}
  JsonValue document() {
    JsonValue v = value();
    skip_space();
    if (at_ != s_.size()) fail("text after the value");
    return v;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("JSON: " + what + " at offset " + std::to_string(at_));
  }
  void skip_space() {
    while (at_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[at_]))) ++at_;
  }
  bool take(char c) {
    skip_space();
    if (at_ < s_.size() && s_[at_] == c) return ++at_, true;
    return false;
  }
  bool take_word(const std::string& w) {
    if (s_.compare(at_, w.size(), w) != 0) return false;
    at_ += w.size();
    return true;
  }
  std::string string_value() {
    if (!take('"')) fail("a string expected");
    std::string out;
    while (at_ < s_.size() && s_[at_] != '"') {
      char c = s_[at_++];
      if (c == '\\' && at_ < s_.size()) {
        const char e = s_[at_++];
        c = e == 'n' ? '\n' : e == 't' ? '\t' : e;
      }
      out += c;
    }
    if (at_++ >= s_.size()) fail("an unterminated string");
    return out;
  }
  JsonValue value() {
    skip_space();
    JsonValue v;
    if (at_ >= s_.size()) fail("a value expected");
    const char c = s_[at_];
    if (c == '{') {
      v.kind = JsonValue::Object;
      ++at_;
      if (take('}')) return v;
      do {
        std::string key = string_value();
        if (!take(':')) fail("':' expected");
        v.members.push_back(JsonMember{std::move(key), value()});
      } while (take(','));
      if (!take('}')) fail("'}' expected");
    } else if (c == '[') {
      v.kind = JsonValue::Array;
      ++at_;
      if (take(']')) return v;
      do {
        v.items.push_back(value());
      } while (take(','));
      if (!take(']')) fail("']' expected");
    } else if (c == '"') {
      v.kind = JsonValue::String;
      v.text = string_value();
    } else if (take_word("null")) {
    } else if (take_word("true")) {
      v.kind = JsonValue::Bool;
      v.boolean = true;
    } else if (take_word("false")) {
      v.kind = JsonValue::Bool;
    } else {
      v.kind = JsonValue::Number;
      std::size_t used = 0;
      v.number = std::stod(s_.substr(at_, 32), &used);
      at_ += used;
    }
    return v;
  }

  const std::string& s_;
  std::size_t at_ = 0;
};

JsonValue read_json(const fs::path& path) { return JsonReader(read_text(path)).document(); }

class BenchCli : public mctstereo::test::FolderTest {
 protected:

  // Runs `mctstereo bench ARGS --data <the bundled Tsukuba>` in the test folder; stderr (progress)
  // goes to stderr.txt there unless `with_stderr`.
  Result bench(const std::string& args, bool with_stderr = false) const {
    const std::string command = "cd " + shell_quoted(folder_.string()) + " && " + shell_quoted(kProgram.string()) +
                                " bench " + args + " --data " + shell_quoted((kData / "tsukuba").string()) +
                                (with_stderr ? " 2>&1" : " 2>stderr.txt");
    return run_shell(command);
  }
  std::string stderr_text() const { return read_text(folder_ / "stderr.txt"); }

  void expect_usage_error(const std::string& args, const std::string& message) const {
    const Result r = bench(args, true);
    EXPECT_EQ(r.status, 2) << "bench " << args << "\n" << r.output;
    EXPECT_EQ(r.output.rfind("mctstereo: error: " + message, 0), 0u)
        << "bench " << args << "\nexpected: mctstereo: error: " << message << "...\ngot: " << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << "one line expected:\n" << r.output;
    EXPECT_FALSE(fs::exists(folder_ / "b.json")) << args;
  }
};

const std::vector<std::string> kStages = {"gray", "pyramid", "census", "match", "refine", "wmedian", "output", "frame"};

TEST_F(BenchCli, LoadAndTheOpenmpWaitAreReported) {
  // Without a setting of the user's, the program runs with a short OpenMP spin; a user's setting
  // stays. --load starts its busy process and reports it.
  const auto run = [&](const std::string& env, const std::string& args) {
    const std::string command = "cd " + shell_quoted(folder_.string()) + " && env -u GOMP_SPINCOUNT -u OMP_WAIT_POLICY " +
                                env + " " + shell_quoted(kProgram.string()) + " bench --sizes 64x48 --presets realtime " +
                                "--num-disparities 16 --frames 1 --warmup 0 --min-time 0 --json b.json " + args +
                                " --data " + shell_quoted((kData / "tsukuba").string()) + " 2>stderr.txt";
    const Result r = run_shell(command);
    EXPECT_EQ(r.status, 0) << command << "\n" << r.output << stderr_text();
    return read_json(folder_ / "b.json")["settings"];
  };
  JsonValue settings = run("", "--load 2");
  EXPECT_EQ(settings["gomp_spincount"].text, "10000");
  EXPECT_EQ(settings["omp_wait_policy"].text, "");
  EXPECT_EQ(settings["load_threads"].number, 2);
  settings = run("GOMP_SPINCOUNT=500", "");
  EXPECT_EQ(settings["gomp_spincount"].text, "500");
  EXPECT_EQ(settings["load_threads"].number, 0);
  settings = run("OMP_WAIT_POLICY=passive", "");
  EXPECT_EQ(settings["gomp_spincount"].text, "");
  EXPECT_EQ(settings["omp_wait_policy"].text, "passive");
  // The load process ends with the timing: none is left behind.
  EXPECT_NE(run_shell("pgrep -f -- '--load-prob[e]' >/dev/null").status, 0);
  fs::remove(folder_ / "b.json");
  expect_usage_error("--load -1 --json b.json", "--load: ");
  expect_usage_error("--load 5000 --json b.json", "--load: ");
}

TEST_F(BenchCli, ListsGiveOneRecordPerCombination) {
  const Result r = bench(
      "--sizes 96x64,128x96 --num-disparities 16,32 --threads 1,2 --backend cpu,reference --presets realtime "
      "--frames 2 --warmup 0 --min-time 0 --json b.json");
  ASSERT_EQ(r.status, 0) << r.output << stderr_text();
  const JsonValue report = read_json(folder_ / "b.json");

  // (method, width, num_disparities, threads_requested, backend) of every record, each once.
  std::multiset<std::tuple<std::string, int, int, int, std::string>> seen;
  for (const JsonValue& rec : report["records"].items) {
    const std::string backend = rec.has("backend") ? rec["backend"].text : "-";
    seen.insert({rec["method"].text, static_cast<int>(rec["width"].number),
                 static_cast<int>(rec["num_disparities"].number), static_cast<int>(rec["threads_requested"].number),
                 backend});
    EXPECT_GE(rec["frames"].number, 2);
    EXPECT_GT(rec["median_ms"].number, 0);
    EXPECT_GE(rec["p95_ms"].number, rec["median_ms"].number);
    // Of two frames the mean is the median (the mean of the middle two), at most the larger frame
    // (the 95th percentile by nearest rank) and at least half of it.
    if (rec["frames"].number == 2) {
      EXPECT_NEAR(rec["mean_ms"].number, rec["median_ms"].number, 1e-9 * rec["median_ms"].number);
      EXPECT_LE(rec["mean_ms"].number, rec["p95_ms"].number);
      EXPECT_GE(rec["mean_ms"].number, rec["p95_ms"].number / 2);
    }
    // The process's CPU time per wall-clock second: some, and with one thread at most one core's
    // (a little over for the clocks' granularity).
    EXPECT_GT(rec["cpu_cores"].number, 0.0);
    if (rec["threads_requested"].number == 1) EXPECT_LE(rec["cpu_cores"].number, 1.25) << rec["method"].text;
    if (rec["method"].text == "opencv-stereobm") EXPECT_EQ(rec["ratio_to_stereobm"].number, 1.0);
    if (rec["kind"].text == "opencv") {
      EXPECT_FALSE(rec.has("stage_median_ms"));
      EXPECT_EQ(rec["threads"].number, rec["threads_requested"].number);
      continue;
    }
    // The reference backend is single-threaded; the cpu backend uses the threads asked for.
    EXPECT_EQ(rec["threads"].number, backend == "reference" ? 1 : rec["threads_requested"].number);
    const JsonValue& stages = rec["stage_median_ms"];
    ASSERT_EQ(stages.members.size(), kStages.size());
    for (std::size_t s = 0; s < kStages.size(); ++s) {
      EXPECT_EQ(stages.members[s].first, kStages[s]);
      EXPECT_GE(stages.members[s].second.number, 0.0) << kStages[s];
      // "frame" is the whole call: no stage's median can exceed it.
      EXPECT_LE(stages.members[s].second.number, stages["frame"].number) << kStages[s];
    }
    EXPECT_GT(stages["frame"].number, 0.0);
    // realtime: 4 levels, both views; the coarsest (1/8) searches 0 .. ceil((d - 1) / 8).
    const JsonValue& work = rec["level_work"];
    ASSERT_EQ(work.items.size(), 4u);
    EXPECT_EQ(work.items[0]["width"].number, rec["width"].number);
    EXPECT_EQ(work.items[3]["views"].number, 2);
    EXPECT_EQ(work.items[3]["candidates"].number, rec["num_disparities"].number == 16 ? 3.0 : 5.0);
  }
  std::multiset<std::tuple<std::string, int, int, int, std::string>> expected;
  for (int width : {96, 128})
    for (int d : {16, 32}) {
      for (int t : {1, 2}) {
        expected.insert({"opencv-stereobm", width, d, t, "-"});
        expected.insert({"opencv-stereosgbm", width, d, t, "-"});
        expected.insert({"realtime", width, d, t, "cpu"});
      }
      expected.insert({"realtime", width, d, 1, "reference"});  // timed once, with the first --threads
    }
  EXPECT_EQ(seen, expected);
  // The table has one row per record: 8 StereoBM rows among them.
  std::size_t stereobm_rows = 0;
  for (std::size_t at = 0; (at = r.output.find(" opencv-stereobm ", at)) != std::string::npos; ++at) ++stereobm_rows;
  EXPECT_EQ(stereobm_rows, 8u) << r.output;
  EXPECT_NE(r.output.find("per-stage medians"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("matching work: "), std::string::npos) << r.output;

  const JsonValue& settings = report["settings"];
  for (const char* key : {"cpu_model", "simd_target", "compiler", "build_type", "mctstereo_version", "opencv_version"})
    EXPECT_FALSE(settings[key].text.empty()) << key;
  EXPECT_GE(settings["cores_online"].number, 1);
  EXPECT_GE(settings["openmp_max_threads"].number, 1);
  EXPECT_EQ(settings["date"].text.size(), std::string("2025-01-31T12:00:00Z").size()) << settings["date"].text;
  ASSERT_EQ(settings["backends"].items.size(), 2u);
  EXPECT_EQ(settings["backends"].items[1].text, "reference");
  ASSERT_EQ(settings["thread_settings"].items.size(), 2u);
  EXPECT_EQ(settings["thread_settings"].items[1].number, 2);
  ASSERT_EQ(settings["num_disparities"].items.size(), 2u);
  EXPECT_EQ(settings["num_disparities"].items[1].number, 32);
  EXPECT_EQ(settings["backend"].text, "cpu");  // the first of each list, as one-value runs report
  EXPECT_EQ(settings["threads_requested"].number, 1);

  // One memory record per (size, range, preset), on the cpu backend with the most threads asked.
  const JsonValue& memory = report["memory"];
  ASSERT_EQ(memory["records"].items.size(), 4u);
  std::set<std::pair<int, int>> memory_seen;
  for (const JsonValue& rec : memory["records"].items) {
    memory_seen.insert({static_cast<int>(rec["width"].number), static_cast<int>(rec["num_disparities"].number)});
    EXPECT_EQ(rec["method"].text, "realtime");
    EXPECT_EQ(rec["backend"].text, "cpu");
    EXPECT_EQ(rec["threads"].number, 2);
    EXPECT_GT(rec["estimate_memory_bytes"].number, 0);
    EXPECT_GT(rec["peak_resident_bytes"].number, 0);
  }
  EXPECT_EQ(memory_seen, (std::set<std::pair<int, int>>{{96, 16}, {96, 32}, {128, 16}, {128, 32}}));
  EXPECT_EQ(memory["estimate_size"].text, "128x96");
  EXPECT_GT(memory["estimate_memory_bytes"]["realtime"].number, 0);
  EXPECT_GT(memory["peak_resident_bytes"].number, 0);
}

TEST_F(BenchCli, MatcherMemoryGrowsWithTheSearchWidthNotTheRange) {
  // 1280x720, 64 and 256 disparities: a full cost volume would grow fourfold (by 1280 x 720 x 192
  // x 2 bytes = 337 MiB), the matcher's buffers only by its match scratch rows and the coarsest
  // level's SGM volume (the whole range at a sixteenth of the pixels: 320 x 180 x 48 x 3 bytes =
  // 7.9 MiB more).
  const Result r = bench(
      "--sizes 1280x720 --num-disparities 64,256 --threads 2 --presets balanced --frames 1 --warmup 0 --min-time 0 "
      "--json b.json");
  ASSERT_EQ(r.status, 0) << r.output << stderr_text();
  const JsonValue report = read_json(folder_ / "b.json");
  const auto& records = report["memory"]["records"].items;
  ASSERT_EQ(records.size(), 2u);
  double peak[2], estimate[2];
  for (int k = 0; k < 2; ++k) {
    const int d = k == 0 ? 64 : 256;
    EXPECT_EQ(records[k]["num_disparities"].number, d);
    mctstereo::StereoParams params = mctstereo::preset("balanced");
    params.num_disparities = d;
    mctstereo::MatcherOptions options;
    options.threads = 2;
    EXPECT_EQ(records[k]["estimate_memory_bytes"].number,
              static_cast<double>(mctstereo::estimate_memory(params, 1280, 720, options)));
    peak[k] = records[k]["peak_resident_bytes"].number;
    estimate[k] = records[k]["estimate_memory_bytes"].number;
    // The measurement agrees with the estimate (the matcher touches what it allocates), with room
    // for thread stacks and allocator overhead.
    EXPECT_GT(peak[k], 0.5 * estimate[k]) << d;
    EXPECT_LT(peak[k], 2.0 * estimate[k] + 8 * 1048576.0) << d;
  }
  EXPECT_LT(peak[1], 1.35 * peak[0]) << "64: " << peak[0] << " bytes, 256: " << peak[1] << " bytes";
  EXPECT_NE(r.output.find("1280x720     256  balanced"), std::string::npos) << r.output;
}

TEST_F(BenchCli, MemoryOnlyMeasuresTheMemoryTableAlone) {
  // quality at 1280x720 with 256 disparities: its band SGM in segments of rows by default, within
  // 1.5 x of balanced's memory (the whole volume would take 84 MiB more).
  const Result r = bench("--memory-only --sizes 1280x720 --num-disparities 256 --threads 2 --presets balanced,quality "
                         "--json b.json");
  ASSERT_EQ(r.status, 0) << r.output << stderr_text();
  const JsonValue report = read_json(folder_ / "b.json");
  EXPECT_TRUE(report["settings"]["memory_only"].boolean);
  EXPECT_TRUE(report["records"].items.empty());
  const auto& records = report["memory"]["records"].items;
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[0]["method"].text, "balanced");
  EXPECT_EQ(records[1]["method"].text, "quality");
  const double balanced = records[0]["peak_resident_bytes"].number, quality = records[1]["peak_resident_bytes"].number;
  EXPECT_GT(quality, 0.5 * balanced);
  EXPECT_LT(quality, 1.5 * balanced) << "balanced " << balanced << " bytes, quality " << quality << " bytes";
  EXPECT_EQ(r.output.find("x BM"), std::string::npos) << r.output;  // no timing table
}

TEST_F(BenchCli, ThesisSizesAreOneName) {
  const Result help = bench("--help");
  ASSERT_EQ(help.status, 0) << help.output;
  EXPECT_NE(help.output.find("thesis = 320x240,640x480,1024x768,1280x720,2048x1536,3840x2160"), std::string::npos)
      << help.output;
  // Parsed before any frame is matched: the error names the bad size after 'thesis', and a size
  // given twice through 'thesis' is caught.
  expect_usage_error("--sizes thesis,10x --json b.json", "--sizes: '10x' is not a size");
  expect_usage_error("--sizes thesis,3840x2160 --json b.json", "--sizes: 3840x2160 is given twice");
}

TEST_F(BenchCli, BadListsFailClearly) {
  expect_usage_error("--sizes 10x --json b.json", "--sizes: '10x' is not a size WIDTHxHEIGHT");
  expect_usage_error("--num-disparities 64,x --json b.json", "--num-disparities: 'x' is not a whole number from 1");
  expect_usage_error("--num-disparities 64,0 --json b.json", "--num-disparities: '0' is not a whole number from 1");
  expect_usage_error("--threads -1 --json b.json", "--threads: '-1' is not a whole number from 0");
  expect_usage_error("--threads 1,2,1 --json b.json", "--threads: 1 is given twice");
  expect_usage_error("--backend gpu --json b.json", "--backend: unknown backend 'gpu'");
  expect_usage_error("--backend cpu,reference,cpu --json b.json", "--backend: cpu is given twice");
  expect_usage_error("--fit crop --json b.json", "--fit: crop not in {stretch,tile}");
}

// --fit tile repeats the pair at its own size: at the pair's size it is the stretched frame
// itself, and at twice the size in each direction the matcher searches as many candidates per
// pixel (the same disparities and texture, but for the seams), where the stretched frame has
// doubled disparities and blurred texture.
TEST_F(BenchCli, TiledFramesKeepTheWorkPerPixel) {
  const auto finest_candidates = [&](const std::string& args) {
    const Result r = bench("--presets realtime --threads 1 --frames 1 --warmup 0 --min-time 0 --json b.json " + args);
    EXPECT_EQ(r.status, 0) << r.output << stderr_text();
    const JsonValue report = read_json(folder_ / "b.json");
    EXPECT_EQ(report["settings"]["fit"].text, args.find("tile") != std::string::npos ? "tile" : "stretch");
    for (const JsonValue& rec : report["records"].items)
      if (rec["method"].text == "realtime") return rec["level_work"].items[0]["candidates"].number;
    ADD_FAILURE() << "no realtime record";
    return 0.0;
  };
  const double own = finest_candidates("--sizes 384x288");
  EXPECT_EQ(finest_candidates("--sizes 384x288 --fit tile"), own);
  const double tiled = finest_candidates("--sizes 768x576 --fit tile");
  EXPECT_NEAR(tiled, own, 0.05 * own);
  EXPECT_GT(std::abs(finest_candidates("--sizes 768x576") - own), 0.05 * own) << "stretched: other work per pixel";
}

}  // namespace
