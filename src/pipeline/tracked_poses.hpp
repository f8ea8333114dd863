#pragma once
// The tracked pose of every frame (T_world_sensor, the chain of tracked increments from the start):
// all in memory for a run on the tracker's thread; with the back end on its own thread the newest
// in memory and the older ones in a journal (issue 33), on both sides.
#include <Eigen/Geometry>

#include "hazmap/core/journaled_list.hpp"

namespace hazmap::pipeline_detail {

using TrackedPoses = JournaledList<Eigen::Isometry3d>;

}  // namespace hazmap::pipeline_detail
