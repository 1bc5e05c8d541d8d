#include "python/src/bake.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include "libcpvs/base/error.h"
#include "python/src/errors.h"
#include "python/src/option_flags.h"
#include "tools/cpvs-bake/bake_command.h"

namespace py = pybind11;

namespace cpvs::python {
namespace {

// Thrown inside the bake by its progress hook once the caller asked it to stop.
struct BakeStopped {};

// cpvs-bake's command line for the call: every keyword option becomes its flag (option_flags.h).
std::vector<std::string> commandLine(const std::string& scene, const std::string& output, py::handle lights,
                                     py::handle resolution, py::handle cache, int threads, const py::kwargs& options) {
  std::vector<std::string> args = {"cpvs-bake", scene, "-o", output, "--quiet", "-r", optionText(resolution)};
  if (!lights.is_none()) args.insert(args.end(), {"--lights", optionText(lights)});
  if (!cache.is_none()) args.insert(args.end(), {"--cache", optionText(cache)});
  if (threads < 0 || threads > 256) raiseArgumentError("threads: 0 (every core) to 256");
  if (threads > 0) args.insert(args.end(), {"--threads", std::to_string(threads)});
  appendOptionFlags(args, options, {"--watch", "--output", "--quiet", "--dump-depth"}, "cpvs.bake");
  return args;
}

}  // namespace

py::dict bake(const std::string& scene, const std::string& output, py::handle lights, py::handle resolution,
              py::handle cache, int threads, py::handle progress, const py::kwargs& options) {
  requireFile(scene, "scene");
  tools::BakeCommand command;
  CLI::App app{"cpvs.bake"};
  command.addTo(app);
  const std::vector<std::string> args = commandLine(scene, output, lights, resolution, cache, threads, options);
  parseOptionFlags(app, args, "cpvs.bake");
  const BakeSettings settings = command.settings();

  std::mutex mutex;
  std::condition_variable finished;
  bool done = false;
  std::atomic<double> fraction{0.0};
  std::atomic<bool> stop{false};
  std::exception_ptr error;
  tools::BakeOutcome outcome;
  std::thread worker([&] {
    try {
      outcome = tools::bakeOnce(command, settings, "cpvs.bake(scene, output)", [&](double f) {
        fraction = f;
        if (stop) throw BakeStopped{};
      });
    } catch (...) {
      error = std::current_exception();
    }
    const std::lock_guard<std::mutex> lock(mutex);
    done = true;
    finished.notify_all();
  });
  const auto stopAndJoin = [&] {
    stop = true;
    py::gil_scoped_release release;
    worker.join();
  };
  for (;;) {
    {
      py::gil_scoped_release release;
      std::unique_lock<std::mutex> lock(mutex);
      finished.wait_for(lock, std::chrono::milliseconds(100), [&] { return done; });
      if (done) break;
    }
    if (PyErr_CheckSignals() != 0) {  // Ctrl-C: KeyboardInterrupt once the bake has stopped
      stopAndJoin();
      throw py::error_already_set();
    }
    if (!progress.is_none()) {
      py::object answer;
      try {
        answer = progress(fraction.load());
      } catch (...) {
        stopAndJoin();
        throw;
      }
      if (answer.ptr() == Py_False) {
        stopAndJoin();
        raiseCancelled("cpvs.bake: cancelled by the progress callback; " + output + " was not written");
      }
    }
  }
  worker.join();
  if (error) {
    try {
      std::rethrow_exception(error);
    } catch (const BakeStopped&) {
      raiseCancelled("cpvs.bake: cancelled; " + output + " was not written");
    }
  }
  if (!progress.is_none()) progress(1.0);
  return py::module_::import("json").attr("loads")(outcome.report.dump());
}

}  // namespace cpvs::python
