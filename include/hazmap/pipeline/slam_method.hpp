#pragma once
// The five methods of the paper's Table 2.
#include <array>
#include <string>

namespace hazmap {

enum class SlamMethod {
  Odometry,        ///< wheel odometry only
  Icp,             ///< conventional frame-to-frame ICP from the odometry guess
  IcpPgo,          ///< ICP + pose-graph optimisation with distance-based loop search
  PropertyIcp,     ///< the paper's ICP with physical properties (eq. 2)
  PropertyIcpPgo,  ///< property ICP + PGO with property-landmark loops (the paper's method)
};

inline constexpr std::array<SlamMethod, 5> kAllSlamMethods{
    SlamMethod::Odometry, SlamMethod::Icp, SlamMethod::IcpPgo, SlamMethod::PropertyIcp,
    SlamMethod::PropertyIcpPgo};

/// "odometry", "icp", "icp+pgo", "property-icp", "property-icp+pgo".
const char* toString(SlamMethod method);
/// Row title as in the paper's Table 2.
const char* paperRowTitle(SlamMethod method);
/// The paper's Table 2 map error (m) for the method.
double paperMapError(SlamMethod method);
/// Throws hazmap::Error naming the valid methods.
SlamMethod parseSlamMethod(const std::string& text);

inline bool usesIcp(SlamMethod m) { return m != SlamMethod::Odometry; }
inline bool usesClasses(SlamMethod m) {
  return m == SlamMethod::PropertyIcp || m == SlamMethod::PropertyIcpPgo;
}
inline bool usesPoseGraph(SlamMethod m) {
  return m == SlamMethod::IcpPgo || m == SlamMethod::PropertyIcpPgo;
}

}  // namespace hazmap
