#pragma once
// Writing the evaluation: summary.json, CSV tables per run, a text table, and the plot
// description that scripts/mfot-plot turns into PNG files.
//
// Files written into the output directory, per run NAME:
//   NAME_frames.csv       frame,segmented,points,accuracy,fitting_mean_m,predicted_objects
//   NAME_objects.csv      one row per ground-truth object: mapping, lost, pose error summary
//   NAME_pose_errors.csv  frame,groundtruth_id,predicted_id,translation_mm,rotation_deg,observable_rotation_deg
//   NAME_segments.csv     where the scene points went: one row per (ground-truth id, predicted id) pair
//                         seen, with the ground-truth id the predicted one maps to, the points, their
//                         share of all scene points and of the ground-truth id's, and the frames it
//                         occurs in (a seam between touching objects shows in most frames)
// and once: summary.json (every number of the table and more) and plots.json.

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "mfot/evaluate/evaluation.hpp"

namespace mfot::evaluate {

// Run names become file names: letters, digits, '_', '-', '.' only; throws EvaluationError.
void check_run_name(const std::string& name);

void write_run_tables(const std::filesystem::path& out_dir, const RunResult& run);
void write_summary_json(const std::filesystem::path& file, const std::vector<RunResult>& runs,
                        const EvaluationOptions& options);
void print_table(std::ostream& out, const std::vector<RunResult>& runs, const EvaluationOptions& options);

// Up to `count` evaluated frames spread evenly over the run (first and last included).
std::vector<std::int64_t> spread_segmented_frames(const RunResult& run, std::size_t count);

// Writes plots.json for scripts/mfot-plot: fitting distance over time of every run that has
// fitting.csv (one figure), pose error over time per run, and predicted-vs-ground-truth
// segmentation of `segmentation_frames` (frames a run has no labels for are skipped).
void write_plot_spec(const std::filesystem::path& file, const std::filesystem::path& out_dir,
                     const std::vector<RunResult>& runs, const GroundTruth& groundtruth,
                     const std::vector<std::vector<std::int64_t>>& segmentation_frames,
                     const EvaluationOptions& options);

}  // namespace mfot::evaluate
