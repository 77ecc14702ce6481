#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "mfot/part_boundary.hpp"

namespace mfot {
namespace {

constexpr float kStep = 0.005f;  // the preprocessing's voxel leaf: scene points 5 mm apart
constexpr Rgb8 kRed{200, 40, 40};
constexpr Rgb8 kBlue{40, 60, 210};
constexpr Rgb8 kWhite{235, 235, 235};

struct Scene {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Rgb8> colors;
  std::vector<int> truth;   // the object each point belongs to
  std::vector<int> labels;  // the parts the discovery gave

  void add(const Eigen::Vector3f& p, Rgb8 color, int object, int label) {
    positions.push_back(p);
    colors.push_back(color);
    truth.push_back(object);
    labels.push_back(label);
  }
  std::size_t wrong() const {
    std::size_t n = 0;
    for (std::size_t i = 0; i < labels.size(); ++i) n += labels[i] != truth[i] ? 1 : 0;
    return n;
  }
};

PartBoundaryOptions options() {
  PartBoundaryOptions o;
  o.radius = 0.03f;
  o.min_color_ratio = 4.f;
  return o;
}

// Two flush faces in the plane z = 1 m: object 0 (red) for x < 0, object 1 (blue) for x >= 0. The
// discovery gave part 0 everything left of strip_end, so a strip of object 1 sits in part 0.
Scene flush_faces(float strip_end) {
  Scene s;
  for (int ix = -20; ix < 20; ++ix) {
    for (int iy = 0; iy < 20; ++iy) {
      const float x = (static_cast<float>(ix) + 0.5f) * kStep;
      const int object = x < 0.f ? 0 : 1;
      s.add({x, static_cast<float>(iy) * kStep, 1.f}, object == 0 ? kRed : kBlue, object, x < strip_end ? 0 : 1);
    }
  }
  return s;
}

TEST(PartBoundary, StripOfAFlushFaceMovesToTheObjectItsColourContinues) {
  Scene s = flush_faces(0.02f);
  ASSERT_EQ(s.wrong(), 4u * 20u);
  PartBoundaryRefiner refiner(options());
  const std::vector<int> before = s.labels;
  EXPECT_EQ(refiner.refine(s.positions, s.colors, s.labels), 3u * 20u);
  for (std::size_t i = 0; i < s.labels.size(); ++i) {
    if (s.truth[i] == 0) {
      EXPECT_EQ(s.labels[i], 0) << "object 0's point at x " << s.positions[i].x();
    } else if (s.positions[i].x() > kStep) {
      EXPECT_EQ(s.labels[i], 1) << "strip point at x " << s.positions[i].x();
    } else {
      // The strip's column next to object 0: a third of its part's patch is red, so it stays.
      EXPECT_EQ(s.labels[i], before[i]);
    }
  }
}

TEST(PartBoundary, RightBoundariesStay) {
  Scene s = flush_faces(0.f);
  PartBoundaryRefiner refiner(options());
  EXPECT_EQ(refiner.refine(s.positions, s.colors, s.labels), 0u);
}

TEST(PartBoundary, SpecksOfAPrintThatMatchTheNeighbourStay) {
  // Object 0's face is printed: every fourth point (a sparse grid of specks) in object 1's blue.
  Scene s = flush_faces(0.f);
  for (std::size_t i = 0; i < s.positions.size(); ++i) {
    const int ix = static_cast<int>(std::lround(s.positions[i].x() / kStep - 0.5f));
    const int iy = static_cast<int>(std::lround(s.positions[i].y() / kStep));
    if (s.truth[i] == 0 && ix % 2 == 0 && iy % 2 == 0) s.colors[i] = kBlue;
  }
  PartBoundaryRefiner refiner(options());
  EXPECT_EQ(refiner.refine(s.positions, s.colors, s.labels), 0u);
  EXPECT_EQ(s.wrong(), 0u);
}

TEST(PartBoundary, AConcaveEdgeIsNotCrossedWhateverTheColours) {
  // Object 0: a floor (z = 1 m, y in [0, 100) mm); object 1: a wall rising from its edge (y = 0). The
  // floor's strip next to the wall is painted in the wall's blue, but it does not continue the wall.
  Scene s;
  for (int ix = 0; ix < 20; ++ix) {
    const float x = static_cast<float>(ix) * kStep;
    for (int iy = 0; iy < 20; ++iy) {
      const float y = (static_cast<float>(iy) + 0.5f) * kStep;
      s.add({x, y, 1.f}, y < 0.02f ? kBlue : kRed, 0, 0);
    }
    for (int iz = 1; iz <= 20; ++iz) s.add({x, 0.f, 1.f - static_cast<float>(iz) * kStep}, kBlue, 1, 1);
  }
  PartBoundaryRefiner refiner(options());
  EXPECT_EQ(refiner.refine(s.positions, s.colors, s.labels), 0u);
}

TEST(PartBoundary, AFlushFaceColouredLikeTheNeighboursOtherFacesStays) {
  // Stacked boxes flush at one end (mOSD learn17): part 0 (red, and a blue end face for x in [-15, 0) mm)
  // meets part 1 in the plane z = 1 m, where part 1's face is white; part 1's other face, a wall at
  // x = 60 mm, is blue. The blue end face matches part 1's colours but not the white face it continues.
  Scene s;
  for (int iy = 0; iy < 20; ++iy) {
    const float y = static_cast<float>(iy) * kStep;
    for (int ix = -20; ix < 12; ++ix) {
      const float x = (static_cast<float>(ix) + 0.5f) * kStep;
      if (x < 0.f) {
        s.add({x, y, 1.f}, x < -0.015f ? kRed : kBlue, 0, 0);
      } else {
        s.add({x, y, 1.f}, kWhite, 1, 1);
      }
    }
    for (int iz = 1; iz <= 30; ++iz) s.add({0.06f, y, 1.f - static_cast<float>(iz) * kStep}, kBlue, 1, 1);
  }
  PartBoundaryRefiner refiner(options());
  EXPECT_EQ(refiner.refine(s.positions, s.colors, s.labels), 0u);
}

TEST(PartBoundary, ResultDoesNotDependOnPointOrder) {
  const Scene s = flush_faces(0.025f);
  std::vector<std::size_t> order(s.positions.size());
  std::iota(order.begin(), order.end(), 0);
  std::reverse(order.begin(), order.end());
  std::rotate(order.begin(), order.begin() + 37, order.end());
  Scene shuffled;
  for (const std::size_t i : order) shuffled.add(s.positions[i], s.colors[i], s.truth[i], s.labels[i]);
  Scene direct = s;
  PartBoundaryRefiner refiner(options());
  refiner.refine(direct.positions, direct.colors, direct.labels);
  refiner.refine(shuffled.positions, shuffled.colors, shuffled.labels);
  for (std::size_t k = 0; k < order.size(); ++k) EXPECT_EQ(shuffled.labels[k], direct.labels[order[k]]);
}

TEST(PartBoundary, OffOrOnePartChangesNothing) {
  Scene s = flush_faces(0.02f);
  PartBoundaryOptions off = options();
  off.radius = 0.f;
  PartBoundaryRefiner none(off);
  EXPECT_EQ(none.refine(s.positions, s.colors, s.labels), 0u);
  std::fill(s.labels.begin(), s.labels.end(), 0);
  PartBoundaryRefiner refiner(options());
  EXPECT_EQ(refiner.refine(s.positions, s.colors, s.labels), 0u);
  std::vector<int> empty;
  EXPECT_EQ(refiner.refine({}, {}, empty), 0u);
}

TEST(PartBoundary, BadOptionsAndInputsAreRejected) {
  PartBoundaryOptions o = options();
  o.radius = -0.01f;
  EXPECT_THROW(PartBoundaryRefiner{o}, std::invalid_argument);
  o.radius = 0.3f;
  EXPECT_THROW(PartBoundaryRefiner{o}, std::invalid_argument);
  o = options();
  o.min_color_ratio = 1.f;
  EXPECT_THROW(PartBoundaryRefiner{o}, std::invalid_argument);
  Scene s = flush_faces(0.f);
  s.labels.pop_back();
  PartBoundaryRefiner refiner(options());
  EXPECT_THROW(refiner.refine(s.positions, s.colors, s.labels), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
