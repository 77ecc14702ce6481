// mfot-evaluate: offline evaluation of recorded runs against simulator ground truth (issue 7,
// thesis chapter 4). See mfot/evaluate/evaluation.hpp for the inputs and the metric choices.
//
//   mfot-evaluate --groundtruth GT --run jcsd=runs/jcsd --run p2p=runs/p2p --out eval/
//
// Writes summary.json, per-run CSV tables and plots.json into --out, prints a table, and runs
// scripts/mfot-plot on plots.json (PNG figures) unless --no-plots.

#include <spawn.h>
#include <sys/wait.h>

#include <CLI/CLI.hpp>
#include <iostream>
#include <sstream>

#include "mfot/evaluate/evaluation.hpp"
#include "mfot/evaluate/report.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using namespace mfot::evaluate;

struct RunArgument {
  std::string name;
  fs::path directory;
};

RunArgument parse_run(const std::string& text) {
  const auto eq = text.find('=');
  RunArgument run;
  if (eq == std::string::npos) {
    run.directory = text;
    run.name = fs::path(text).lexically_normal().filename().string();
    if (run.name.empty()) run.name = fs::path(text).lexically_normal().parent_path().filename().string();
  } else {
    run.name = text.substr(0, eq);
    run.directory = text.substr(eq + 1);
  }
  check_run_name(run.name);
  return run;
}

std::vector<std::int64_t> parse_frames(const std::string& text) {
  std::vector<std::int64_t> frames;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      std::size_t used = 0;
      const long long frame = std::stoll(item, &used);
      if (used != item.size() || frame < 0) throw std::invalid_argument(item);
      frames.push_back(frame);
    } catch (const std::exception&) {
      throw EvaluationError("--segmentation-frames: '" + item + "' is not a frame number");
    }
  }
  return frames;
}

// Runs the plot script without a shell (paths may contain anything); returns its exit status.
int run_plotter(const std::string& plotter, const fs::path& spec) {
  std::vector<std::string> args{plotter, spec.string()};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, plotter.c_str(), nullptr, nullptr, argv.data(), environ) != 0) return -1;
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mfot-evaluate: segmentation accuracy, relative pose error, tracks lost and fitting distance of "
      "recorded runs against simulator ground truth"};
  std::string groundtruth_dir, out_dir, frames_text, plotter = MFOT_PLOT_SCRIPT;
  std::vector<std::string> run_texts;
  EvaluationOptions options;
  bool no_plots = false;
  app.add_option("--groundtruth", groundtruth_dir, "ground-truth directory (poses.csv, labels/, optional depth/)")
      ->required();
  app.add_option("--run", run_texts, "run directory, optionally named: NAME=DIR (repeat for several methods)")
      ->required();
  app.add_option("--out", out_dir, "output directory (created)")->required();
  app.add_option("--segmentation-frames", frames_text,
                 "comma-separated frames to plot segmentation for (default: 3 spread over the run)");
  app.add_option("--translation-threshold-mm", options.translation_threshold_mm, "pose error threshold")
      ->capture_default_str();
  app.add_option("--rotation-threshold-deg", options.rotation_threshold_deg, "pose error threshold")
      ->capture_default_str();
  app.add_flag("--no-plots", no_plots, "do not run the plot script");
  app.add_option("--plotter", plotter, "plot script (reads plots.json)")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    options.validate();
    std::vector<RunArgument> run_args;
    for (const auto& t : run_texts) {
      run_args.push_back(parse_run(t));
      for (std::size_t k = 0; k + 1 < run_args.size(); ++k) {
        if (run_args[k].name == run_args.back().name) {
          throw EvaluationError("two runs are named '" + run_args.back().name + "'; name them with --run NAME=DIR");
        }
      }
    }
    const auto chosen_frames = frames_text.empty() ? std::vector<std::int64_t>{} : parse_frames(frames_text);
    const GroundTruth groundtruth = load_groundtruth(groundtruth_dir);
    std::vector<RunResult> runs;
    for (const auto& r : run_args) runs.push_back(evaluate_run(r.name, r.directory, groundtruth, options));

    const fs::path out(out_dir);
    std::error_code ec;
    fs::create_directories(out, ec);
    if (ec) throw EvaluationError(out.string() + ": cannot create directory: " + ec.message());
    for (const auto& run : runs) write_run_tables(out, run);
    write_summary_json(out / "summary.json", runs, options);
    std::vector<std::vector<std::int64_t>> segmentation_frames;
    for (const auto& run : runs) {
      segmentation_frames.push_back(chosen_frames.empty() ? spread_segmented_frames(run, 3) : chosen_frames);
    }
    write_plot_spec(out / "plots.json", out, runs, groundtruth, segmentation_frames, options);
    print_table(std::cout, runs, options);
    std::cout << "\nwrote " << (out / "summary.json").string() << " and the CSV tables in " << out.string() << '\n';

    if (!no_plots) {
      std::cout.flush();  // the plot script's lines come after the table
      const int status = run_plotter(plotter, out / "plots.json");
      if (status != 0) {
        std::cerr << "mfot-evaluate: plotting failed (" << plotter << " exited with " << status
                  << "; it needs python3 with matplotlib); the numbers above are complete\n";
        return 3;
      }
    }
  } catch (const EvaluationError& e) {
    std::cerr << "mfot-evaluate: " << e.what() << '\n';
    return 1;
  } catch (const std::invalid_argument& e) {
    std::cerr << "mfot-evaluate: " << e.what() << '\n';
    return 2;
  }
  return 0;
}
