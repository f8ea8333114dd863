// Verification by property-aware ICP (kept apart from the pure acceptance rules so that those
// link without the registration stage).
#include "hazmap/loop/verification.hpp"

namespace hazmap {

VerificationResult verifyCandidate(const LoopCandidate& cand, const LabeledCloud& query_cloud,
                                   const LabeledCloud& match_cloud, const ClassTable& classes,
                                   const VerificationConfig& c) {
  validate(c);
  if (query_cloud.empty() || match_cloud.empty()) {
    VerificationResult out;
    out.rejection = LoopRejection::EmptyCloud;
    out.reason = "empty keyframe cloud";
    out.closure.from = cand.match;
    out.closure.to = cand.query;
    return out;
  }
  const RegistrationResult reg =
      registerClouds(query_cloud, match_cloud, cand.initial_guess, classes, c.registration);
  return evaluateRegistration(cand, reg, c);
}

}  // namespace hazmap
