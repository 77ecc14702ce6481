// Object discovery on real scenes: every organised PCD file of a folder with a `label` field (mOSD)
// as one scene, through mfot's preprocessing and first-frame objects (merger.discovery), scored per
// measured pixel against the file's labels (match_segments: found, WOv, merged, split, spurious),
// and PCL's LCCP with its example's settings after a RANSAC table fit on the same points.
// Points left in no object: of the ground-truth object pixels above the table (those mfot's
// preprocessing keeps a voxel of), how many no object holds; the same pixels for both methods.
// One JSON object per scene and method on stdout; scripts/bench-mosd prints the tables.
//
//   mfot_bench_discovery FOLDER [--config FILE] [--background-label-max 9] [--no-pcl]

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "../../services/capture/pcd/pcd_image.hpp"
#include "mfot/capture/pcd_source.hpp"
#include "mfot/metrics.hpp"
#include "mfot/object_manager.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "pcl_lccp_reference.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// above_table: per measured pixel, whether mfot's preprocessing kept a voxel of it.
void print(const std::string& scene, const char* method, const std::vector<std::int32_t>& truth,
           const std::vector<std::int32_t>& predicted, const std::vector<std::uint8_t>& above_table, double ms,
           double table_ms) {
  const mfot::SegmentMatch m = mfot::match_segments(truth, predicted);
  std::size_t object_points = 0, unassigned = 0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    if (truth[k] == 0 || !above_table[k]) continue;
    ++object_points;
    if (predicted[k] == 0) ++unassigned;
  }
  std::printf(
      "{\"scene\": \"%s\", \"method\": \"%s\", \"segments\": %zu, \"objects\": %zu, \"found\": %zu, \"wov\": %.5f, "
      "\"merged\": %zu, \"split\": %zu, \"spurious\": %zu, \"object_points\": %zu, \"unassigned\": %zu, "
      "\"ms\": %.3f, \"table_ms\": %.3f}\n",
      scene.c_str(), method, m.segments, m.objects, m.found, m.weighted_overlap, m.merged, m.split, m.spurious,
      object_points, unassigned, ms, table_ms);
  std::fflush(stdout);
}

// Colour | labels | labels as one binary PPM; a label's colour is a hash of it, 0 is black.
void write_side_by_side(const std::string& path, const mfot::capture::PcdImage& image,
                        const std::vector<std::int32_t>& truth, const std::vector<std::int32_t>& predicted) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) throw std::runtime_error("cannot write " + path);
  std::fprintf(f, "P6\n%d %d\n255\n", 3 * image.width, image.height);
  const auto label_color = [](std::int32_t label, unsigned char* rgb) {
    const auto h = static_cast<std::uint32_t>(label) * 2654435761u;
    for (int c = 0; c < 3; ++c) rgb[c] = label == 0 ? 0 : static_cast<unsigned char>(64 + ((h >> (8 * c)) & 0xbf));
  };
  for (int v = 0; v < image.height; ++v) {
    for (int panel = 0; panel < 3; ++panel) {
      for (int u = 0; u < image.width; ++u) {
        const std::size_t i =
            static_cast<std::size_t>(v) * static_cast<std::size_t>(image.width) + static_cast<std::size_t>(u);
        unsigned char rgb[3];
        if (panel == 0) {
          for (int c = 0; c < 3; ++c) rgb[c] = image.rgb[3 * i + static_cast<std::size_t>(c)];
        } else {
          label_color(panel == 1 ? truth[i] : predicted[i], rgb);
        }
        std::fwrite(rgb, 1, 3, f);
      }
    }
  }
  std::fclose(f);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Object discovery on labelled organised PCD scenes (mfot and PCL's LCCP), JSON lines"};
  std::string folder, config_path;
  unsigned background_label_max = 9;
  bool no_pcl = false;
  std::string dump;
  app.add_option("folder", folder, "folder of organised PCD files with a label field")->required();
  app.add_option("--config", config_path, "config laid over configs/default.yaml");
  app.add_option("--background-label-max", background_label_max, "labels up to this are background (mOSD: 9)");
  app.add_flag("--no-pcl", no_pcl, "leave out PCL's LCCP");
  app.add_option("--dump", dump, "write SCENE.ppm here: colour | ground truth | mfot's objects, side by side");
  CLI11_PARSE(app, argc, argv);

  try {
    const YAML::Node config = config_path.empty() ? mfot::service::merged_over_defaults(YAML::Node())
                                                  : mfot::service::load_config_file(config_path);
    const auto preprocess = mfot::service::load_preprocess_config(config);
    const auto merger = mfot::service::load_merger_config(config);
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::directory_iterator(folder)) {
      if (entry.path().extension() == ".pcd") files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end(),
              [](const auto& a, const auto& b) { return mfot::capture::natural_less(a.string(), b.string()); });
    if (files.empty()) throw std::runtime_error("no .pcd files in " + folder);

    for (const auto& path : files) {
      mfot::capture::PcdImage image;
      std::string error;
      if (!mfot::capture::read_organised_pcd(path.string(), image, error)) {
        std::fprintf(stderr, "[bench-discovery] %s: %s (skipped)\n", path.c_str(), error.c_str());
        continue;
      }
      if (image.label.empty()) {  // no ground truth: every object counts as spurious (see --dump)
        std::fprintf(stderr, "[bench-discovery] %s: no label field: objects only\n", path.c_str());
        image.label.assign(image.xyz.size() / 3, 0);
      }
      const std::string scene = path.stem().string();
      const std::size_t pixels = image.label.size();
      std::vector<std::int32_t> truth, predicted;
      std::vector<std::size_t> measured;
      for (std::size_t i = 0; i < pixels; ++i) {
        if (!std::isfinite(image.xyz[3 * i + 2])) continue;
        measured.push_back(i);
        truth.push_back(image.label[i] > background_label_max ? static_cast<std::int32_t>(image.label[i]) : 0);
      }

      // mfot: preprocessing, then the first frame's objects (discovery at birth).
      const mfot::service::Frame frame = mfot::capture::frame_from_organised_cloud(image);
      mfot::Preprocessor preprocessor(preprocess.preprocessor);
      const auto t_table = Clock::now();
      const mfot::SceneCloud& cloud = preprocessor.process(mfot::service::image_view(frame));
      const double table_ms = ms_since(t_table);
      mfot::ColoredCloud points;
      points.positions = cloud.positions;
      points.colors = cloud.colors;
      mfot::ObjectManager manager(merger.manager, mfot::make_object_discovery(merger.manager.discovery));
      const auto t_objects = Clock::now();
      const auto& result = manager.process(points, cloud.cluster, cloud.standing_clusters, {});
      const double objects_ms = ms_since(t_objects);
      const auto voxel_of_pixel = preprocessor.pixel_voxel_index();
      predicted.clear();
      std::vector<std::uint8_t> above_table;
      for (const std::size_t i : measured) {
        const int voxel = voxel_of_pixel[i];
        predicted.push_back(voxel < 0 ? 0 : result.labels[static_cast<std::size_t>(voxel)]);
        above_table.push_back(voxel >= 0 ? 1 : 0);
      }
      print(scene, "mfot", truth, predicted, above_table, objects_ms, table_ms);
      if (!dump.empty()) {
        std::vector<std::int32_t> truth_image(pixels, 0), predicted_image(pixels, 0);
        for (std::size_t k = 0; k < measured.size(); ++k) {
          truth_image[measured[k]] = truth[k];
          predicted_image[measured[k]] = predicted[k];
        }
        write_side_by_side(dump + "/" + scene + ".ppm", image, truth_image, predicted_image);
      }

      if (no_pcl) continue;
      const auto reference = mfot::bench::pcl_lccp_segments(image.xyz, image.rgb);
      predicted.clear();
      for (const std::size_t i : measured) predicted.push_back(reference.labels[i]);
      print(scene, "pcl-lccp", truth, predicted, above_table, reference.segment_ms, reference.table_ms);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "[bench-discovery] %s\n", e.what());
    return 1;
  }
  return 0;
}
