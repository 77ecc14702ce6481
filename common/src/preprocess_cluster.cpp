// Step 5 of Preprocessor: Euclidean clustering of the voxels. Same result as EuclideanClusterer
// (connected components of "distance <= tolerance", numbered by their lowest point index, at
// least cluster_min_size points), computed for speed as a union-find over a grid of cells whose
// diagonal is just under the tolerance (side tolerance / sqrt(3), less a margin of kCellMargin
// that covers float rounding), instead of one sorted radius search per point:
//  1. every point of a cell is within the tolerance of every other: a cell is one component;
//  2. two cells can hold a close pair only when no coordinate differs by more than 2 cells (the
//     62 forward neighbour offsets): for each such pair of non-empty cells not yet in one
//     component, pairs of their points are tested until the first one within the tolerance.
// The components (the transitive closure of "within the tolerance") are the same as testing every
// pair; only pairs whose test could not change them are skipped.
// With threads, the cells' neighbour tests run in parallel on a concurrent union-find (links
// always hang the higher root under the lower one, by compare-and-swap): whatever the order of
// the unions, every component ends with its lowest point as root, so labels are the same.

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>

#include "mfot/preprocessing.hpp"

namespace mfot {

namespace {

constexpr int kCellBits = 21;
constexpr std::uint64_t kEmptyCell = ~std::uint64_t{0};
constexpr float kCellMin = -static_cast<float>(1 << (kCellBits - 1));
constexpr float kCellMax = static_cast<float>((1 << (kCellBits - 1)) - 1);

std::uint64_t pack_cell(const Eigen::Vector3i& c) {
  constexpr std::int64_t offset = std::int64_t{1} << (kCellBits - 1);
  constexpr std::uint64_t mask = (std::uint64_t{1} << kCellBits) - 1;
  return (static_cast<std::uint64_t>(c.x() + offset) & mask) |
         ((static_cast<std::uint64_t>(c.y() + offset) & mask) << kCellBits) |
         ((static_cast<std::uint64_t>(c.z() + offset) & mask) << (2 * kCellBits));
}

std::size_t cell_hash(std::uint64_t key) {
  std::uint64_t h = key * 0x9E3779B97F4A7C15ull;
  h ^= h >> 29;
  return static_cast<std::size_t>(h);
}

// Cells are this much smaller than tolerance / sqrt(3): two points of one cell are then closer
// than the tolerance also after float rounding of their cell coordinates and of the distance test.
constexpr float kCellMargin = 1e-4f;

// The offsets in [-2, 2]^3 lexicographically after (0, 0, 0): with the cell itself they cover every
// unordered pair of cells that may hold two points within the tolerance (cells 3 apart along an axis
// are at least 2 sides = 1.15 tolerances apart) once.
constexpr int kNeighbourReach = 2;
constexpr std::size_t kForwardNeighbours = 62;  // ((2 * 2 + 1)^3 - 1) / 2
constexpr std::array<std::array<int, 3>, kForwardNeighbours> forward_offsets() {
  std::array<std::array<int, 3>, kForwardNeighbours> out{};
  std::size_t k = 0;
  for (int x = -kNeighbourReach; x <= kNeighbourReach; ++x) {
    for (int y = -kNeighbourReach; y <= kNeighbourReach; ++y) {
      for (int z = -kNeighbourReach; z <= kNeighbourReach; ++z) {
        if (x > 0 || (x == 0 && (y > 0 || (y == 0 && z > 0)))) out[k++] = {x, y, z};
      }
    }
  }
  return out;
}
constexpr std::array<std::array<int, 3>, kForwardNeighbours> kForwardOffsets = forward_offsets();

// Union-find on a plain array through std::atomic_ref, so the neighbour tests of different cells
// may run on different threads. A parent never has a higher index than its child, and a node that
// stops being a root never becomes one again, so path halving may store any ancestor it read.
int find_root(std::vector<int>& parent, int i) {
  for (;;) {
    const int p = std::atomic_ref<int>(parent[static_cast<std::size_t>(i)]).load(std::memory_order_acquire);
    if (p == i) return i;
    const int grandparent = std::atomic_ref<int>(parent[static_cast<std::size_t>(p)]).load(std::memory_order_acquire);
    if (grandparent != p) {
      std::atomic_ref<int>(parent[static_cast<std::size_t>(i)]).store(grandparent, std::memory_order_release);
    }
    i = grandparent;
  }
}

void unite(std::vector<int>& parent, int a, int b) {
  for (;;) {
    a = find_root(parent, a);
    b = find_root(parent, b);
    if (a == b) return;
    // The lower index becomes the root, so roots do not depend on the order of unions.
    if (a > b) std::swap(a, b);
    int expected = b;  // b may have been linked meanwhile: then find its root again
    if (std::atomic_ref<int>(parent[static_cast<std::size_t>(b)])
            .compare_exchange_strong(expected, a, std::memory_order_acq_rel)) {
      return;
    }
  }
}

}  // namespace

int Preprocessor::find_cluster_cell(const Eigen::Vector3i& cell) const {
  const std::uint64_t key = pack_cell(cell);
  std::size_t slot = cell_hash(key) & cell_slot_mask_;
  while (cell_slot_keys_[slot] != kEmptyCell) {
    if (cell_slot_keys_[slot] == key) return cell_slot_ids_[slot];
    slot = (slot + 1) & cell_slot_mask_;
  }
  return -1;
}

void Preprocessor::cluster_voxels() {
  const std::vector<Eigen::Vector3f>& points = scene_.positions;
  const std::size_t n = points.size();
  scene_.cluster.assign(n, -1);
  scene_.num_clusters = 0;
  if (!options_.cluster || n == 0) return;

  // Cells: an open-addressing table from packed cell coordinates to a dense cell id.
  std::size_t capacity = 64;
  while (capacity < 2 * n) capacity *= 2;
  cell_slot_keys_.assign(capacity, kEmptyCell);
  cell_slot_ids_.resize(capacity);
  cell_slot_mask_ = capacity - 1;
  cell_coords_.clear();
  cell_start_.clear();
  point_cell_.resize(n);
  point_cell_coords_.resize(n);
  const float inv_cell = std::sqrt(3.f) / (options_.cluster_tolerance * (1.f - kCellMargin));
  split_evenly(n, kMinPreprocessPointsPerPiece);
  pool_.run(pieces_.size(), [this, inv_cell](std::size_t p) {
    for (std::size_t i = pieces_[p].begin; i < pieces_[p].end; ++i) {
      const Eigen::Vector3f scaled =
          (scene_.positions[i] * inv_cell).array().floor().cwiseMax(kCellMin).cwiseMin(kCellMax);
      point_cell_coords_[i] = scaled.cast<int>();
    }
  });
  // Dense cell ids in order of first appearance: on this thread.
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3i cell = point_cell_coords_[i];
    const std::uint64_t key = pack_cell(cell);
    std::size_t slot = cell_hash(key) & cell_slot_mask_;
    while (cell_slot_keys_[slot] != kEmptyCell && cell_slot_keys_[slot] != key) slot = (slot + 1) & cell_slot_mask_;
    if (cell_slot_keys_[slot] == kEmptyCell) {
      cell_slot_keys_[slot] = key;
      cell_slot_ids_[slot] = static_cast<int>(cell_coords_.size());
      cell_coords_.push_back(cell);
      cell_start_.push_back(0);
    }
    const int id = cell_slot_ids_[slot];
    point_cell_[i] = id;
    ++cell_start_[static_cast<std::size_t>(id)];
  }

  // Counting sort by cell: positions become contiguous per cell (slots [start[c], start[c + 1])).
  const std::size_t cells = cell_coords_.size();
  int running = 0;
  for (std::size_t c = 0; c < cells; ++c) {
    const int count = cell_start_[c];
    cell_start_[c] = running;
    running += count;
  }
  cell_start_.push_back(running);
  cell_fill_.assign(cell_start_.begin(), cell_start_.end() - 1);
  sorted_positions_.resize(n);
  sorted_to_point_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const int slot = cell_fill_[static_cast<std::size_t>(point_cell_[i])]++;
    sorted_positions_[static_cast<std::size_t>(slot)] = points[i];
    sorted_to_point_[static_cast<std::size_t>(slot)] = static_cast<int>(i);
  }

  // Union-find over point indices (not slots), so a component's root is its lowest point.
  union_parent_.resize(n);
  for (std::size_t i = 0; i < n; ++i) union_parent_[i] = static_cast<int>(i);
  const float tolerance2 = options_.cluster_tolerance * options_.cluster_tolerance;
  // Step 2 for cells a and b: true once a pair of their points within the tolerance is united.
  const auto link_first_pair = [&](int a_begin, int a_end, int b_begin, int b_end) {
    for (int a = a_begin; a < a_end; ++a) {
      const Eigen::Vector3f pa = sorted_positions_[static_cast<std::size_t>(a)];
      for (int b = b_begin; b < b_end; ++b) {
        if ((sorted_positions_[static_cast<std::size_t>(b)] - pa).squaredNorm() <= tolerance2) {
          unite(union_parent_, sorted_to_point_[static_cast<std::size_t>(a)],
                sorted_to_point_[static_cast<std::size_t>(b)]);
          return;
        }
      }
    }
  };
  const auto link_cells = [this, &link_first_pair](std::size_t first, std::size_t last) {
    for (std::size_t c = first; c < last; ++c) {
      const int begin = cell_start_[c];
      const int end = cell_start_[c + 1];
      const int head = sorted_to_point_[static_cast<std::size_t>(begin)];
      for (int a = begin + 1; a < end; ++a) unite(union_parent_, head, sorted_to_point_[static_cast<std::size_t>(a)]);
      for (const auto& offset : kForwardOffsets) {
        const int neighbour = find_cluster_cell(cell_coords_[c] + Eigen::Vector3i(offset[0], offset[1], offset[2]));
        if (neighbour < 0) continue;
        const int n_begin = cell_start_[static_cast<std::size_t>(neighbour)];
        // Already one component (a stale answer on another thread only costs the tests below).
        if (find_root(union_parent_, head) ==
            find_root(union_parent_, sorted_to_point_[static_cast<std::size_t>(n_begin)])) {
          continue;
        }
        link_first_pair(begin, end, n_begin, cell_start_[static_cast<std::size_t>(neighbour) + 1]);
      }
    }
  };
  // Cells hold very different numbers of points: more pieces than threads balance the load.
  const std::size_t link_pieces =
      pool_.threads() == 1 ? 1 : kPreprocessPiecesPerThread * static_cast<std::size_t>(pool_.threads());
  pool_.run(link_pieces, [cells, link_pieces, &link_cells](std::size_t p) {
    link_cells(cells * p / link_pieces, cells * (p + 1) / link_pieces);
  });

  // Component sizes at their roots, then labels in order of the roots (lowest point index).
  component_size_.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const int root = find_root(union_parent_, static_cast<int>(i));
    union_parent_[i] = root;
    ++component_size_[static_cast<std::size_t>(root)];
  }
  const auto min_size = options_.cluster_min_size;
  for (std::size_t i = 0; i < n; ++i) {
    const auto root = static_cast<std::size_t>(union_parent_[i]);  // root <= i: labelled already
    if (root == i) {
      const int size = component_size_[i];
      // component_size_ of a root turns into its label (or -1) once the root is reached.
      component_size_[i] = size >= min_size ? scene_.num_clusters++ : -1;
    }
    scene_.cluster[i] = component_size_[root];
  }
}

}  // namespace mfot
