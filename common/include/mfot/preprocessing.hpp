#pragma once
// Frame -> scene cloud: the preprocessing of thesis chapter 4 ("the point-cloud data of a table
// are first excluded using a plane extraction method, then ... downsampled with 5 mm sampling
// distance using VoxelGrid filter"), plus the Euclidean clustering of section 3.1 that seeds
// object models in non-contact scenes. Steps of Preprocessor::process:
//   1. back-project the registered depth image (uint16 millimetres, 0 = no measurement) with the
//      pinhole intrinsics into coloured camera-frame points (metres);
//   2. workspace crop: keep points inside an axis-aligned box of the camera frame;
//   3. table removal: a RANSAC plane (fixed iteration count, own seeded generator, least-squares
//      refinement on its inliers) is kept between frames and refitted only when its inlier share
//      drops; points more than a margin above it on the camera side survive;
//   4. voxel downsampling (5 mm leaf): mean position and mean colour per voxel, one source pixel
//      per voxel (the first in raster order), voxels ordered by that pixel. With voxel_jitter the
//      grid's corner moves each frame to a random point of one leaf, drawn from the seed and the
//      frame's seq (a counter-based draw: the same frame gives the same grid in any replay). On a
//      fixed grid a surface at rest yields the same pattern of voxel means in every frame, so
//      point-to-point ICP onto a model sampled from that surface locks onto the pose the model
//      was sampled at, and holds back a box that starts to turn from there (docs/experiment-log.md:
//      "A voxel grid that moves every frame");
//   5. Euclidean clustering of the voxels: connected components of "closer than the tolerance"
//      of at least cluster_min_size voxels (no upper bound: a pile is one cluster), numbered by their first voxel
//      (EuclideanClusterer's result, computed by a grid union-find, about 5x faster on 5 mm voxels);
//   6. table prism (as PCL's ExtractPolygonalPrismData, own code because it runs per frame on the
//      core's types): the convex hull of the plane's inliers (an even-stride sample; their largest
//      connected region on a 2 cm grid, as a wall's foot is an inlier too) is the table's support
//      polygon; a cluster with less than prism_min_share of its voxels above
//      it (a wall, shelves or people beside the table) does not stand: it never becomes an
//      object (it keeps its points together, so that an object tracked into it, as a gripper's arm
//      raised beyond the table's far edge, labels the rest of it), unless it rests on the table: prism_min_share of it
//      lies above the hull of every inlier region of at least a quarter of the largest's samples (a pile, or an arm
//      reaching over the table, cuts the visible top into such regions) and either its lowest voxel lies within 2 cm of
//      the height below which step 3 removed the table (standing on it, not held above), or at least half of its foot
//      (its voxels within 1 cm of its lowest) is hidden: just below each in the image lies, first, a nearer voxel of a
//      cluster that stands (an object behind a pile's front ones; repeated while clusters join), or the image's bottom
//      edge. The margin of step 3 grows with depth as the sensor's noise does: at least plane_margin_sigmas x sigma(z),
//      sigma(z) = base + quadratic (z - reference)^2 (Nguyen, Izadi, Lovell 2012, Kinect v1), so a far table's noise
//      does not become objects.
// After warm-up (the first frame of the largest size) nothing is allocated per frame.
// With threads > 1, steps 1-2, the plane split of step 3, the voxel keys of step 4 and the cell
// keys and neighbour tests of step 5 run on a ThreadPool: rows, points and cells are split into
// pieces whose outputs are disjoint or integer counts placed in order, and clusters are joined by
// a concurrent union-find whose result depends only on which voxels are close, so the scene is
// bit-identical for every thread count. The RANSAC fit stays on the calling thread.

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "mfot/thread_pool.hpp"
#include "mfot/types.hpp"
#include "mfot/voxel_grid.hpp"

namespace mfot {

// Pieces of parallel preprocessing smaller than these are not worth waking a thread for (~10 us).
inline constexpr std::size_t kMinPreprocessRowsPerPiece = 8;
inline constexpr std::size_t kMinPreprocessPointsPerPiece = 4096;
inline constexpr std::size_t kPreprocessPiecesPerThread = 4;

// Pinhole intrinsics of the registered depth/colour image, pixels.
struct CameraIntrinsics {
  float fx = 570.3f;
  float fy = 570.3f;
  float cx = 319.5f;
  float cy = 239.5f;
};

// A registered RGB-D image: depth aligned to colour, both row-major width x height.
struct RgbdImageView {
  int width = 0;
  int height = 0;
  CameraIntrinsics intrinsics;
  std::span<const std::uint16_t> depth_mm;  // 0 = no measurement
  std::span<const Rgb8> color;
};

// Plane a x + b y + c z + d = 0 in the camera frame with unit normal (a, b, c) pointing to the
// camera side, i.e. d > 0 and the signed distance n.p + d is positive above the table.
struct TablePlane {
  Eigen::Vector4f coefficients = Eigen::Vector4f::Zero();
  bool valid = false;

  float signed_distance(const Eigen::Vector3f& p) const { return coefficients.head<3>().dot(p) + coefficients[3]; }
};

// The preprocessed scene of one frame; every per-point vector has the same length.
struct SceneCloud {
  std::vector<Eigen::Vector3f> positions;  // voxel mean, metres, camera frame
  std::vector<Rgb8> colors;                // voxel mean colour (rounded)
  std::vector<std::int16_t> pixel_u;       // column of the first pixel (raster order) in the voxel
  std::vector<std::int16_t> pixel_v;       // row of that pixel
  std::vector<int> cluster;                // in [0, num_clusters), -1 = in no cluster (too small)
  int num_clusters = 0;
  // Clusters [0, standing_clusters) stand on the table (step 6) and may become objects; the others (off the table:
  // a wall, a person beside it, a gripper's arm beyond its far edge) only carry the labels of objects tracked in them.
  int standing_clusters = 0;
  TablePlane plane;      // the plane used for this frame (invalid: none removed)
  VoxelGrid voxel_grid;  // step 4's grid of this frame (leaf 0 before the first frame)

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  void clear();
};

// Voxel-grid downsampling with integer voxel keys in an open-addressing hash table: O(n), one
// pass, deterministic. Voxel i is the i-th distinct voxel met in input order, so raster-ordered
// input gives voxels ordered by their first pixel.
class VoxelDownsampler {
 public:
  // leaf_size in metres, finite and in (0, 1].
  explicit VoxelDownsampler(float leaf_size);
  VoxelDownsampler(const VoxelDownsampler&) = delete;
  VoxelDownsampler& operator=(const VoxelDownsampler&) = delete;

  // Replaces the voxel set with the voxels of the input points (which must be finite);
  // colours and source ids have the input's length. Returns the voxel count. With a pool, the
  // points' voxel keys are computed on it (the same voxels for any pool).
  std::size_t downsample(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8> colors,
                         std::span<const std::uint32_t> source_ids, ThreadPool* pool = nullptr);

  // Moves the grid: voxels become the cells floor((p - origin) / leaf_size) from the next
  // downsample() on (the origin starts at zero). Throws std::invalid_argument for a non-finite origin.
  void set_grid_origin(const Eigen::Vector3f& origin);
  const Eigen::Vector3f& grid_origin() const { return grid_origin_; }

  float leaf_size() const { return leaf_size_; }
  std::size_t size() const { return mean_positions_.size(); }
  std::span<const Eigen::Vector3f> positions() const { return mean_positions_; }     // mean per voxel
  std::span<const Rgb8> colors() const { return mean_colors_; }                      // rounded mean
  std::span<const std::uint32_t> first_source_ids() const { return first_source_; }  // of the first input point
  std::span<const int> point_counts() const { return counts_; }
  std::span<const int> voxel_of_input() const { return voxel_of_input_; }  // per input point

  // Index of the voxel of the last downsample() containing p, or -1 (empty voxel, non-finite p).
  int voxel_index_of(const Eigen::Vector3f& p) const;

 private:
  std::uint64_t key_of(const Eigen::Vector3f& p) const;
  int find_or_insert(std::uint64_t key, std::uint32_t source_id);

  float leaf_size_;
  float inv_leaf_;
  Eigen::Vector3f grid_origin_ = Eigen::Vector3f::Zero();
  // Slots are valid when their stamp equals the current generation, so no per-frame clearing.
  std::vector<std::uint64_t> slot_keys_;
  std::vector<int> slot_voxels_;
  std::vector<std::uint32_t> slot_stamps_;
  std::uint32_t generation_ = 0;
  std::size_t slot_mask_ = 0;

  std::vector<Eigen::Vector3f> mean_positions_;
  std::vector<Eigen::Vector3f> sums_;
  std::vector<Eigen::Vector3i> color_sums_;
  std::vector<Rgb8> mean_colors_;
  std::vector<std::uint32_t> first_source_;
  std::vector<int> counts_;
  std::vector<int> voxel_of_input_;
  std::vector<std::uint64_t> input_keys_;  // per input point
};

struct PlaneFitOptions {
  int iterations = 100;           // RANSAC hypotheses per fit, in [1, 100000]
  int sample_points = 2048;       // points hypotheses are scored on (even stride), in [3, 1000000]
  float inlier_distance = 0.01f;  // metres, in (0, 0.5]
  float min_inlier_share = 0.1f;  // of all points, to accept a fit as the table, in (0, 1]
  std::uint64_t seed = 0x7AB1E;   // of the fitter's generator

  // Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

// RANSAC plane fit: `iterations` three-point hypotheses scored on an even-stride sample, the best
// refined by least squares (PCA) on its inliers among all points. Deterministic for a seed and a
// call sequence.
class PlaneFitter {
 public:
  explicit PlaneFitter(PlaneFitOptions options = {});
  PlaneFitter(const PlaneFitter&) = delete;
  PlaneFitter& operator=(const PlaneFitter&) = delete;

  const PlaneFitOptions& options() const { return options_; }

  // The dominant plane (normal towards the origin), invalid when fewer than min_inlier_share of
  // the points lie within inlier_distance of the best one. inlier_share gets the fit's share.
  TablePlane fit(std::span<const Eigen::Vector3f> points, float* inlier_share = nullptr);

 private:
  PlaneFitOptions options_;
  std::mt19937_64 rng_;
  std::vector<Eigen::Vector3f> sample_;
};

// Member defaults: the thesis's values, for library users and unit tests; the services and
// mfot-inprocess fill every field from configs/default.yaml (the shipped defaults).
struct PreprocessorOptions {
  // Workspace crop box in the camera frame, metres (min < max per axis).
  Eigen::Vector3f crop_min{-1.5f, -1.5f, 0.3f};
  Eigen::Vector3f crop_max{1.5f, 1.5f, 2.0f};

  bool remove_plane = true;
  PlaneFitOptions plane_fit;
  float plane_margin = 0.01f;       // keep points with signed distance > margin, metres, in [0, 0.5]
  float plane_margin_sigmas = 0.f;  // ... or this many depth-noise sigmas if more, in [0, 10]; 0 = fixed margin
  Eigen::Vector3f depth_sigma{0.0012f, 0.0019f, 0.4f};  // base m, quadratic m/m^2, reference m; each in [0, 1]
  bool table_prism = false;                             // clusters must stand on the table's support polygon (step 6)
  float prism_min_share = 0.25f;  // least share of a cluster's voxels above the polygon, in (0, 1]
  // The kept plane is refitted when its inlier share falls below this fraction of the share it
  // had when fitted (the camera or the table moved), in (0, 1].
  float plane_keep_ratio = 0.7f;

  float voxel_size = 0.005f;            // leaf, metres, in (0, 1]
  bool voxel_jitter = false;            // step 4's grid corner drawn per frame within one leaf (false: at the origin)
  std::uint64_t voxel_jitter_seed = 0;  // keys that draw together with the frame's seq

  bool cluster = true;
  float cluster_tolerance = 0.015f;  // metres, in (0, 1]
  int cluster_min_size = 30;         // voxels, >= 1: smaller clusters are rejected (-1); none is too large

  int threads = 1;  // threads of the per-frame work, the caller included, in [1, 64]

  // Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

// 2D convex hull (Andrew's monotone chain): counter-clockwise, without collinear points; fewer
// than three distinct points give those points.
std::vector<Eigen::Vector2f> convex_hull(std::vector<Eigen::Vector2f> points);
// p inside or on the counter-clockwise convex polygon (at least three vertices).
bool inside_convex_polygon(std::span<const Eigen::Vector2f> hull, const Eigen::Vector2f& p);

// Per-frame statistics and stage timings (steady clock, milliseconds).
struct PreprocessStats {
  std::size_t valid_depth = 0;  // pixels with depth
  std::size_t cropped = 0;      // points inside the crop box
  std::size_t above_plane = 0;  // points surviving table removal
  std::size_t voxels = 0;
  int clusters_off_table = 0;      // clusters that do not stand on the table (step 6)
  float plane_inlier_share = 0.f;  // of the cropped points, for the plane used
  bool plane_refitted = false;     // a RANSAC fit ran this frame
  double backproject_ms = 0.0;     // steps 1 and 2
  double plane_ms = 0.0;           // step 3
  double voxel_ms = 0.0;           // step 4
  double cluster_ms = 0.0;         // step 5
  double total_ms = 0.0;
};

class Preprocessor {
 public:
  explicit Preprocessor(PreprocessorOptions options = {});
  Preprocessor(const Preprocessor&) = delete;
  Preprocessor& operator=(const Preprocessor&) = delete;

  const PreprocessorOptions& options() const { return options_; }

  // Runs steps 1-6 on one frame; frame_seq (the capture's frame counter, which the services pass)
  // keys the voxel grid's draw and matters only with voxel_jitter. The result stays valid until
  // the next call. Throws std::invalid_argument for inconsistent image sizes or invalid intrinsics.
  const SceneCloud& process(const RgbdImageView& image, std::int64_t frame_seq = 0);

  const SceneCloud& scene() const { return scene_; }
  const PreprocessStats& stats() const { return stats_; }

  // The table plane kept between frames (invalid before the first successful fit).
  const TablePlane& plane() const { return plane_; }
  // Forgets the kept plane so the next frame fits a new one.
  void reset_plane();

  // Index into scene() of the voxel that contains camera-frame point p, or -1 when that voxel is
  // not in the scene (for dense labelling of arbitrary points).
  int voxel_index_of(const Eigen::Vector3f& p) const;
  // Scene index of the voxel that pixel (u, v) of the last frame fell into; -1 when the pixel had
  // no depth or was cropped or removed as table, or lies outside the image.
  int voxel_index_at(int u, int v) const;
  // The same for all pixels, row-major width x height of the last frame.
  std::span<const int> pixel_voxel_index() const { return pixel_voxel_; }
  // The table's support polygon of the last frame in the plane's coordinates (table_prism; empty
  // without a plane), and the point p's coordinates there.
  std::span<const Eigen::Vector2f> table_polygon() const { return table_hull_; }
  Eigen::Vector2f on_table_plane(const Eigen::Vector3f& p) const;

 private:
  void backproject_and_crop(const RgbdImageView& image);
  // Splits [0, n) into kPreprocessPiecesPerThread pieces per thread (one piece with one thread),
  // fewer when pieces would be below min_piece, in pieces_.
  void split_evenly(std::size_t n, std::size_t min_piece);
  struct PointBuffers {
    Eigen::Vector3f* positions;
    Rgb8* colors;
    std::uint32_t* pixels;
  };
  // Rows [v_begin, v_end) of steps 1-2: counts valid and cropped pixels and stores the cropped
  // points at `out`.
  void crop_rows(const RgbdImageView& image, int v_begin, int v_end, PointBuffers out, std::size_t& valid,
                 std::size_t& cropped);
  // Points [begin, end) of split_by_plane: counts band inliers and kept points, and with kWrite
  // stores the kept points from index `first` on.
  template <bool kWrite>
  void split_points(const TablePlane& plane, std::size_t begin, std::size_t end, std::size_t first,
                    std::size_t& inliers, std::size_t& kept);
  void remove_table();
  // Signed-distance pass with `plane`: compacts kept points into above_* and returns the share
  // of cropped points within the inlier band.
  float split_by_plane(const TablePlane& plane);
  void cluster_voxels();
  void keep_clusters_on_table();  // step 6
  int find_cluster_cell(const Eigen::Vector3i& cell) const;

  PreprocessorOptions options_;
  ThreadPool pool_;
  // A piece [begin, end) of rows or points of a parallel step: how many points it outputs, where
  // its output starts once the pieces before it are placed, and a count it keeps besides (valid
  // depth pixels, plane inliers).
  struct Piece {
    std::size_t begin = 0;
    std::size_t end = 0;
    std::size_t first = 0;
    std::size_t tally = 0;
    std::size_t output_count = 0;
  };
  std::vector<Piece> pieces_;
  PlaneFitter plane_fitter_;
  VoxelDownsampler voxels_;
  TablePlane plane_;
  float plane_fitted_share_ = 0.f;

  // Per-image ray tables (recomputed when the size or intrinsics change).
  int ray_width_ = 0;
  int ray_height_ = 0;
  CameraIntrinsics ray_intrinsics_{};
  std::vector<float> ray_x_;  // (u - cx) / fx per column
  std::vector<float> ray_y_;  // (v - cy) / fy per row
  int image_width_ = 0;

  // Point buffers sized to the largest image seen; the first *_count_ entries are live.
  std::vector<Eigen::Vector3f> cropped_positions_;
  std::vector<Rgb8> cropped_colors_;
  std::vector<std::uint32_t> cropped_pixels_;  // v * width + u
  std::size_t cropped_count_ = 0;
  std::vector<Eigen::Vector3f> above_positions_;
  std::vector<Rgb8> above_colors_;
  std::vector<std::uint32_t> above_pixels_;
  std::size_t above_count_ = 0;
  bool kept_all_cropped_ = false;  // no plane removed: the cropped buffers are the kept points

  std::vector<int> pixel_voxel_;

  // Table prism scratch (step 6): plane basis, hull, per-cluster tallies.
  Eigen::Vector3f table_axis_u_ = Eigen::Vector3f::UnitX();
  Eigen::Vector3f table_axis_v_ = Eigen::Vector3f::UnitY();
  std::vector<Eigen::Vector2f> table_samples_;
  std::vector<Eigen::Vector2f> table_hull_;
  std::vector<Eigen::Vector2f> table_span_samples_;
  std::vector<Eigen::Vector2f> table_span_hull_;
  std::vector<int> cluster_inside_;
  std::vector<int> cluster_spanned_;
  std::vector<float> cluster_rest_gap_;
  std::vector<int> cluster_foot_;
  std::vector<int> cluster_hidden_foot_;
  std::vector<int> cluster_total_;
  std::vector<int> cluster_renumber_;

  // Clustering scratch (preprocess_cluster.cpp).
  std::vector<std::uint64_t> cell_slot_keys_;
  std::vector<int> cell_slot_ids_;
  std::size_t cell_slot_mask_ = 0;
  std::vector<Eigen::Vector3i> cell_coords_;
  std::vector<Eigen::Vector3i> point_cell_coords_;
  std::vector<int> cell_start_;
  std::vector<int> cell_fill_;
  std::vector<int> point_cell_;
  std::vector<Eigen::Vector3f> sorted_positions_;
  std::vector<int> sorted_to_point_;
  std::vector<int> union_parent_;
  std::vector<int> component_size_;

  SceneCloud scene_;
  PreprocessStats stats_;
};

}  // namespace mfot
