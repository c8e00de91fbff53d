// mctstereo: the command line. Subcommands match, stream, eval, bench, devices and render; every failure
// ends as one line "mctstereo: error: ..." on stderr with exit status 2 (usage) or 1 (runtime).
#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/ocl.hpp>

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <new>
#include <string_view>

#include "bench.hpp"
#include "devices.hpp"
#include "errors.hpp"
#include "eval.hpp"
#include "match.hpp"
#include "options.hpp"
#include "render.hpp"
#include "stream.hpp"

namespace {

int fail(int status, const std::string& message) {
  // Messages are single lines; a stray newline (from a library) must not split the report.
  std::string line = message;
  for (char& c : line)
    if (c == '\n') c = ' ';
  std::cerr << "mctstereo: error: " << line << "\n";
  return status;
}

// libgomp's threads spin up to 300,000 times at every barrier before they sleep. On a loaded CPU
// that spinning eats the time slices of the team-mate they wait for: with 2 threads of another
// process busy on this 2-core machine, a realtime frame at 640 x 480 took 235 ms with 2 threads
// against 15 ms with 1 (`bench --load 2`). A spin of 10,000 keeps the unloaded speed and ends the
// collapse (docs/RESULTS.md). libgomp reads GOMP_SPINCOUNT once, as it loads, so the program sets
// it and starts itself again; a setting of the user's own (GOMP_SPINCOUNT, OMP_WAIT_POLICY) stays.
void restart_with_short_openmp_spin(char** argv) {
  if (std::getenv("GOMP_SPINCOUNT") != nullptr || std::getenv("OMP_WAIT_POLICY") != nullptr) return;
  if (setenv("GOMP_SPINCOUNT", "10000", 0) != 0) return;
  execv("/proc/self/exe", argv);  // returns only when it fails: then run on with the default spin
}

// OpenCV runs some of its own functions (remap, ORB, colour conversion) through OpenCL when it
// finds a device, and a driver that cannot start there (PoCL in a container without /sys) aborts
// the whole process. The program needs none of it: its own OpenCL backend does not go through
// OpenCV. The variable is read when OpenCV first looks for OpenCL, in whichever thread; the call
// covers this thread should OpenCV have looked already. A setting of the user's own stays.
void keep_opencv_off_opencl() {
  setenv("OPENCV_OPENCL_RUNTIME", "disabled", 0);
  cv::ocl::setUseOpenCL(false);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mctstereo::app;
  restart_with_short_openmp_spin(argv);
  keep_opencv_off_opencl();
  CLI::App app{"mctstereo: dense stereo matching on the (modified) census transform, coarse to fine."};
  app.name("mctstereo");
  app.require_subcommand(1);
  app.footer("Run 'mctstereo SUBCOMMAND --help' for the flags of a subcommand.\n");
  MatchCommand match(app);
  StreamCommand stream(app);
  EvalCommand eval(app);
  BenchCommand bench(app);
  DevicesCommand devices(app);
  RenderCommand render(app);
  refuse_empty_and_non_finite_numbers(app);

  // CLI11 would call a misspelt subcommand a stray argument; name it instead.
  if (argc > 1 && argv[1][0] != '-') {
    const std::string_view name = argv[1];
    if (name != "match" && name != "stream" && name != "eval" && name != "bench" && name != "devices" &&
        name != "render")
      return fail(kExitUsage, std::string("unknown subcommand '") + argv[1] +
                                  "' (known: match, stream, eval, bench, devices, render)");
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);  // --help
    return fail(kExitUsage, std::string(e.what()) + " (see --help)");
  }

  try {
    if (match.selected()) match.run();
    if (stream.selected()) stream.run();
    if (eval.selected()) eval.run();
    if (bench.selected()) bench.run();
    if (devices.selected()) devices.run();
    if (render.selected()) render.run();
    // The summary is output too: stdout on a full disk (or > /dev/full) is a failure.
    if (!(std::cout << std::flush))
      return fail(kExitRuntime, std::string("cannot write to stdout: ") + std::strerror(errno));
    return 0;
  } catch (const UsageError& e) {
    return fail(kExitUsage, e.what());
  } catch (const RuntimeError& e) {
    return fail(kExitRuntime, e.what());
  } catch (const std::invalid_argument& e) {
    // The library names the parameter or image it rejects.
    return fail(kExitUsage, e.what());
  } catch (const cv::Exception& e) {
    return fail(kExitRuntime, "OpenCV: " + e.err);
  } catch (const std::bad_alloc&) {
    return fail(kExitRuntime, "out of memory: the memory (or the limit of 'ulimit -v') is too small for this work; "
                              "fewer --threads, a larger --scale or fewer --num-disparities need less");
  } catch (const std::exception& e) {
    return fail(kExitRuntime, e.what());
  }
}
