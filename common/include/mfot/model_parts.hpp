#pragma once
// Editing an object's model as parts (ManagedObject::part_ends): every part is a set of points placed with one
// frame's pose; a model grows by appending a part (a view of a part entering, a joined object, a registered
// remembered model) and stays within a size limit by thinning evenly over its whole extent. Not a step of the thesis,
// whose models are mixed point by point (3.4); used by ObjectManager's growth, joins and re-identification.
// Contracts: part_ends ascend, the last one is the model's size; features hold one SMR feature per point.

#include <cstdint>
#include <span>
#include <vector>

#include "mfot/likelihood.hpp"
#include "mfot/types.hpp"

namespace mfot {

// Indices (ascending) of a spatially even subset of at most max_points of the cloud: the first point of every voxel
// (voxels in order of their first point) of a leaf that grows by 25 % from 2 mm until few enough voxels are occupied;
// beyond a 1 m leaf, the first max_points of those. Earlier points win their voxels, so a model's older points stay
// where newer ones add nothing.
std::vector<std::uint32_t> even_subset(const ColoredCloud& cloud, std::size_t max_points);

// The model's even subset of at most max_points (features kept with their points); part_ends become those of the
// subset, parts left empty dropped.
ObjectModel thinned(ObjectModel model, std::size_t max_points, std::vector<std::uint32_t>& part_ends);

// The model with one part appended (points in the model's frame, with their colours and SMR features, one each),
// then thinned to max_points; part_ends gets the new part's end before thinning.
ObjectModel with_part(ObjectModel model, std::span<const Eigen::Vector3f> points, std::span<const Rgb8> colors,
                      std::span<const SmrFeature> features, std::size_t max_points,
                      std::vector<std::uint32_t>& part_ends);

}  // namespace mfot
