// Step 6 of Preprocessor::process: the table prism (see preprocessing.hpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

#include "mfot/preprocessing.hpp"

namespace mfot {
namespace {

// Inliers the support polygon is built from: an even-stride sample of the cropped points.
constexpr std::size_t kTableSamples = 4096;
// The table is the largest 8-connected region of inlier samples on a grid of this cell (metres):
// where a wall or a post crosses the plane's height its points are inliers too, but apart.
constexpr float kTableCell = 0.02f;
// A pile across the table cuts its visible top into regions of like size: the regions holding at
// least this share of the largest one's samples span the table a cluster may rest on.
constexpr float kTableRegionShare = 0.25f;
// A cluster rests on the table when its lowest voxel lies within this of the height above the plane
// below which points were removed as table (metres): an object standing on it, not an arm above it.
constexpr float kRestSlack = 0.02f;
// A pile hides the feet of the objects behind its front ones. A cluster's foot is its voxels within
// kFootBand of its lowest (metres); a foot voxel is hidden when, looking down the image from its
// pixel (at most kHiddenLookPx rows, past the cluster's own pixels and pixels without a voxel), the
// first other voxel met belongs to a cluster that stands and lies kNearer (metres) nearer the camera,
// or the image ends first (the pile runs out of view towards the camera).
constexpr float kFootBand = 0.01f;
constexpr int kHiddenLookPx = 10;
constexpr float kNearer = 0.01f;

// Moves into `spanned` the samples of the regions (8-connected occupied kTableCell cells) holding at
// least kTableRegionShare of the largest region's samples, and keeps in `samples` the largest's.
void keep_largest_region(std::vector<Eigen::Vector2f>& samples, std::vector<Eigen::Vector2f>& spanned) {
  spanned = samples;
  std::unordered_map<std::uint64_t, int> cell_of_key;
  std::vector<std::uint64_t> keys;
  std::vector<int> cell_of_sample(samples.size());
  std::vector<int> count;
  const auto key = [](long x, long y) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(x)) << 32) | static_cast<std::uint32_t>(y);
  };
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const long x = std::lround(std::floor(samples[i].x() / kTableCell));
    const long y = std::lround(std::floor(samples[i].y() / kTableCell));
    const auto [it, inserted] = cell_of_key.try_emplace(key(x, y), static_cast<int>(keys.size()));
    if (inserted) {
      keys.push_back(key(x, y));
      count.push_back(0);
    }
    cell_of_sample[i] = it->second;
    ++count[static_cast<std::size_t>(it->second)];
  }
  std::vector<int> region(keys.size(), -1);
  std::vector<int> region_count;
  std::vector<int> stack;
  for (std::size_t start = 0; start < keys.size(); ++start) {
    if (region[start] >= 0) continue;
    const int r = static_cast<int>(region_count.size());
    region_count.push_back(0);
    region[start] = r;
    stack.assign(1, static_cast<int>(start));
    while (!stack.empty()) {
      const auto cell = static_cast<std::size_t>(stack.back());
      stack.pop_back();
      region_count[static_cast<std::size_t>(r)] += count[cell];
      const auto x = static_cast<std::int32_t>(keys[cell] >> 32);
      const auto y = static_cast<std::int32_t>(keys[cell] & 0xffffffffu);
      for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          const auto it = cell_of_key.find(key(x + dx, y + dy));
          if (it == cell_of_key.end() || region[static_cast<std::size_t>(it->second)] >= 0) continue;
          region[static_cast<std::size_t>(it->second)] = r;
          stack.push_back(it->second);
        }
      }
    }
  }
  if (region_count.size() <= 1) return;
  const auto largest =
      static_cast<int>(std::max_element(region_count.begin(), region_count.end()) - region_count.begin());
  const float major = kTableRegionShare * static_cast<float>(region_count[static_cast<std::size_t>(largest)]);
  std::size_t kept = 0;
  spanned.clear();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const int r = region[static_cast<std::size_t>(cell_of_sample[i])];
    if (static_cast<float>(region_count[static_cast<std::size_t>(r)]) >= major) spanned.push_back(samples[i]);
    if (r == largest) samples[kept++] = samples[i];
  }
  samples.resize(kept);
}

float cross(const Eigen::Vector2f& o, const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

}  // namespace

std::vector<Eigen::Vector2f> convex_hull(std::vector<Eigen::Vector2f> points) {
  std::sort(points.begin(), points.end(), [](const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  std::vector<Eigen::Vector2f> hull(2 * points.size());
  std::size_t k = 0;
  for (const Eigen::Vector2f& p : points) {  // lower hull
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], p) <= 0.f) --k;
    hull[k++] = p;
  }
  const std::size_t lower = k + 1;
  for (auto it = points.rbegin() + 1; it != points.rend(); ++it) {  // upper hull
    while (k >= lower && cross(hull[k - 2], hull[k - 1], *it) <= 0.f) --k;
    hull[k++] = *it;
  }
  hull.resize(k - 1);  // the last point is the first
  return hull;
}

bool inside_convex_polygon(std::span<const Eigen::Vector2f> hull, const Eigen::Vector2f& p) {
  if (hull.size() < 3) return false;
  for (std::size_t i = 0; i < hull.size(); ++i) {
    if (cross(hull[i], hull[(i + 1) % hull.size()], p) < 0.f) return false;
  }
  return true;
}

Eigen::Vector2f Preprocessor::on_table_plane(const Eigen::Vector3f& p) const {
  return {table_axis_u_.dot(p), table_axis_v_.dot(p)};
}

void Preprocessor::keep_clusters_on_table() {
  table_hull_.clear();
  scene_.standing_clusters = scene_.num_clusters;
  if (!options_.table_prism || !plane_.valid || kept_all_cropped_ || scene_.num_clusters == 0) return;
  // The plane's own basis: any unit vector orthogonal to the normal, and the normal x that.
  const Eigen::Vector3f normal = plane_.coefficients.head<3>();
  table_axis_u_ = normal.unitOrthogonal();
  table_axis_v_ = normal.cross(table_axis_u_);
  const float band = options_.plane_fit.inlier_distance;
  table_samples_.clear();
  const std::size_t stride = std::max<std::size_t>(1, cropped_count_ / kTableSamples);
  for (std::size_t i = 0; i < cropped_count_; i += stride) {
    const Eigen::Vector3f& p = cropped_positions_[i];
    if (std::abs(plane_.signed_distance(p)) < band) table_samples_.push_back(on_table_plane(p));
  }
  keep_largest_region(table_samples_, table_span_samples_);
  table_hull_ = convex_hull(table_samples_);
  if (table_hull_.size() < 3) return;
  table_span_hull_ = convex_hull(table_span_samples_);

  const auto clusters = static_cast<std::size_t>(scene_.num_clusters);
  cluster_inside_.assign(clusters, 0);
  cluster_spanned_.assign(clusters, 0);
  cluster_total_.assign(clusters, 0);
  cluster_rest_gap_.assign(clusters, std::numeric_limits<float>::infinity());
  const float margin = options_.plane_margin;
  const float sigmas = options_.plane_margin_sigmas;
  const Eigen::Vector3f& noise = options_.depth_sigma;
  for (std::size_t k = 0; k < scene_.size(); ++k) {
    const int c = scene_.cluster[k];
    if (c < 0) continue;
    const auto ci = static_cast<std::size_t>(c);
    ++cluster_total_[ci];
    const Eigen::Vector3f& p = scene_.positions[k];
    const Eigen::Vector2f q = on_table_plane(p);
    if (inside_convex_polygon(table_hull_, q)) ++cluster_inside_[ci];
    if (inside_convex_polygon(table_span_hull_, q)) ++cluster_spanned_[ci];
    // as step 3's margin: the height below which points were removed as table
    const float from_reference = p.z() - noise[2];
    const float removed_below = std::max(margin, sigmas * (noise[0] + noise[1] * from_reference * from_reference));
    cluster_rest_gap_[ci] = std::min(cluster_rest_gap_[ci], plane_.signed_distance(p) - removed_below);
  }
  // State per cluster before numbering: 1 stands, 0 off the table, -1 above the spanned table but
  // not resting on it where seen (its foot may be hidden behind a standing cluster).
  cluster_renumber_.assign(clusters, 0);
  for (std::size_t c = 0; c < clusters; ++c) {
    const float needed = options_.prism_min_share * static_cast<float>(cluster_total_[c]);
    if (static_cast<float>(cluster_inside_[c]) >= needed) {
      cluster_renumber_[c] = 1;
    } else if (static_cast<float>(cluster_spanned_[c]) >= needed) {
      cluster_renumber_[c] = cluster_rest_gap_[c] <= kRestSlack ? 1 : -1;
    }
  }
  const auto width = static_cast<std::size_t>(std::max(image_width_, 1));
  const std::size_t rows = pixel_voxel_.size() / width;
  // Passes while clusters join (one hidden behind a cluster found standing in the pass before): at most one per
  // cluster.
  for (std::size_t pass = 0; pass < clusters; ++pass) {
    cluster_foot_.assign(clusters, 0);
    cluster_hidden_foot_.assign(clusters, 0);
    for (std::size_t k = 0; k < scene_.size(); ++k) {
      const int c = scene_.cluster[k];
      if (c < 0 || cluster_renumber_[static_cast<std::size_t>(c)] != -1) continue;
      const auto ci = static_cast<std::size_t>(c);
      const Eigen::Vector3f& p = scene_.positions[k];
      const float from_reference = p.z() - noise[2];
      const float removed_below = std::max(margin, sigmas * (noise[0] + noise[1] * from_reference * from_reference));
      if (plane_.signed_distance(p) - removed_below > cluster_rest_gap_[ci] + kFootBand) continue;
      // A foot voxel counts once the look down meets another voxel or the image's end; one that meets neither
      // (its own cluster or pixels without a voxel, as the table's, all the way) tells nothing.
      const auto u = static_cast<std::size_t>(scene_.pixel_u[k]);
      for (std::size_t v = static_cast<std::size_t>(scene_.pixel_v[k]) + 1;
           v <= static_cast<std::size_t>(scene_.pixel_v[k]) + kHiddenLookPx; ++v) {
        if (v >= rows) {  // the image ends below it: its support is out of view
          ++cluster_foot_[ci];
          ++cluster_hidden_foot_[ci];
          break;
        }
        const int j = pixel_voxel_[v * width + u];
        if (j < 0 || scene_.cluster[static_cast<std::size_t>(j)] == c) continue;
        ++cluster_foot_[ci];
        const int cj = scene_.cluster[static_cast<std::size_t>(j)];
        if (cj >= 0 && cluster_renumber_[static_cast<std::size_t>(cj)] == 1 &&
            scene_.positions[static_cast<std::size_t>(j)].z() < p.z() - kNearer) {
          ++cluster_hidden_foot_[ci];
        }
        break;
      }
    }
    bool changed = false;
    for (std::size_t c = 0; c < clusters; ++c) {
      if (cluster_renumber_[c] == -1 && cluster_foot_[c] > 0 && 2 * cluster_hidden_foot_[c] >= cluster_foot_[c]) {
        cluster_renumber_[c] = 1;
        changed = true;
      }
    }
    if (!changed) break;
  }
  // The standing clusters first, then the others, each in their order (numbered by their first voxel).
  int standing = 0;
  for (std::size_t c = 0; c < clusters; ++c) standing += cluster_renumber_[c] == 1 ? 1 : 0;
  int next_standing = 0, next_off = standing;
  for (std::size_t c = 0; c < clusters; ++c)
    cluster_renumber_[c] = cluster_renumber_[c] == 1 ? next_standing++ : next_off++;
  stats_.clusters_off_table = scene_.num_clusters - standing;
  for (int& c : scene_.cluster) {
    if (c >= 0) c = cluster_renumber_[static_cast<std::size_t>(c)];
  }
  scene_.standing_clusters = standing;
}

}  // namespace mfot
