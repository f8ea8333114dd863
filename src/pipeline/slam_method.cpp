#include "hazmap/pipeline/slam_method.hpp"

#include "hazmap/core/error.hpp"

namespace hazmap {

const char* toString(SlamMethod method) {
  switch (method) {
    case SlamMethod::Odometry: return "odometry";
    case SlamMethod::Icp: return "icp";
    case SlamMethod::IcpPgo: return "icp+pgo";
    case SlamMethod::PropertyIcp: return "property-icp";
    case SlamMethod::PropertyIcpPgo: return "property-icp+pgo";
  }
  return "?";
}

const char* paperRowTitle(SlamMethod method) {
  switch (method) {
    case SlamMethod::Odometry: return "Odometry";
    case SlamMethod::Icp: return "ICP";
    case SlamMethod::IcpPgo: return "ICP with pose graph optimization";
    case SlamMethod::PropertyIcp: return "Proposed ICP";
    case SlamMethod::PropertyIcpPgo: return "Proposed ICP with pose graph optimization";
  }
  return "?";
}

double paperMapError(SlamMethod method) {
  switch (method) {  // Suzuki et al., Table 2 (m)
    case SlamMethod::Odometry: return 0.918;
    case SlamMethod::Icp: return 0.320;
    case SlamMethod::IcpPgo: return 0.322;
    case SlamMethod::PropertyIcp: return 0.023;
    case SlamMethod::PropertyIcpPgo: return 0.011;
  }
  return 0.0;
}

SlamMethod parseSlamMethod(const std::string& text) {
  for (SlamMethod m : kAllSlamMethods)
    if (text == toString(m)) return m;
  fail("method", "unknown method '" + text +
                     "' (expected odometry, icp, icp+pgo, property-icp or property-icp+pgo)");
}

}  // namespace hazmap
