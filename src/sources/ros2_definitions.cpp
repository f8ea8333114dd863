// ros2msg schema texts of the types hazmap writes, in the layout ROS 2 tools expect: the
// type's own fields, then each dependency after a line of '=' and "MSG: <type>".
#include <map>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/mcap_writer.hpp"

namespace hazmap {
namespace {

const std::string kSeparator = "================================================================================\nMSG: ";
const std::string kTime = kSeparator + "builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const std::string kHeader = kSeparator + "std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n" + kTime;
const std::string kPose = kSeparator + "geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n" +
                          kSeparator + "geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n" + kSeparator +
                          "geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";

const std::map<std::string, std::string>& definitions() {
  static const std::map<std::string, std::string> defs = {
      {"sensor_msgs/msg/PointCloud2",
       "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\nbool is_bigendian\n"
       "uint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n" +
           kHeader + kSeparator +
           "sensor_msgs/PointField\nuint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\n"
           "uint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n"},
      {"sensor_msgs/msg/Image",
       "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n" +
           kHeader},
      {"sensor_msgs/msg/CompressedImage", "std_msgs/Header header\nstring format\nuint8[] data\n" + kHeader},
      {"sensor_msgs/msg/Imu",
       "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n"
       "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
       "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n" +
           kHeader + kSeparator + "geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n" +
           kSeparator + "geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"},
      {"nav_msgs/msg/Odometry",
       "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
       "geometry_msgs/TwistWithCovariance twist\n" +
           kHeader + kSeparator + "geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\nfloat64[36] covariance\n" +
           kPose + kSeparator + "geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\nfloat64[36] covariance\n" +
           kSeparator + "geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n" +
           kSeparator + "geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"},
      {"geometry_msgs/msg/PoseStamped", "std_msgs/Header header\ngeometry_msgs/Pose pose\n" + kHeader + kPose},
      {"std_msgs/msg/String", "string data\n"},
  };
  return defs;
}

}  // namespace

const std::string& ros2MessageDefinition(const std::string& ros2_type) {
  const auto it = definitions().find(ros2_type);
  if (it == definitions().end()) fail("MCAP writer", "no message definition for type '" + ros2_type + "'");
  return it->second;
}

}  // namespace hazmap
