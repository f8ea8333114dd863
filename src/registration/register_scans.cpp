#include <tbb/parallel_invoke.h>

#include <optional>

#include "hazmap/core/error.hpp"
#include "hazmap/registration/registration.hpp"
#include "hazmap/registration/registration_target.hpp"
#include "thread_arena.hpp"

namespace hazmap {

RegistrationResult registerScans(const LabeledCloud& source, const LabeledCloud& target,
                                 const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                                 const VoxelDownsampleConfig& downsample,
                                 const RegistrationConfig& config) {
  // Everything registerClouds would reject is rejected before any work.
  config.validate();
  if (!isFinite(initial_guess)) fail("registration", "initial guess has a non-finite entry");
  source.checkConsistent("registration source");
  target.checkConsistent("registration target");
  if (config.use_classes) {
    classes.checkCloud(source, "registration source");
    classes.checkCloud(target, "registration target");
  }
  RegistrationResult result;
  detail::runWithThreads(config.threads, [&] {
    LabeledCloud small_source;
    std::optional<RegistrationTarget> prepared;
    // Faster than downsampling one cloud after the other (measured: docs/measurements.md).
    tbb::parallel_invoke(
        [&] { small_source = voxelDownsample(source, downsample, classes); },
        [&] { prepared.emplace(voxelDownsample(target, downsample, classes), classes, config,
                               std::vector<Eigen::Vector3f>{}, std::vector<char>{}); });
    result = registerClouds(small_source, *prepared, initial_guess, classes, config);
  });
  return result;
}

}  // namespace hazmap
