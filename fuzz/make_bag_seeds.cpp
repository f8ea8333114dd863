// Builds the seed corpus of the bag fuzz targets: small MCAPs written by hazmap's writer in
// each compression (and one cut short), small ROS 1 bags in each chunk compression (indexed or
// not), a small rosbag2 .db3 with its metadata.yaml, the real nebula metadata.yaml, and
// single messages (CDR and ROS 1) for the decoder target.
// Usage: hazmap_fuzz_bag_seeds SHARED_DATA_DIR OUT_DIR   (OUT_DIR/run_0.db3 is the
// HAZMAP_FUZZ_DB3 file fuzz_rosbag2 points its metadata.yaml at)
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <iostream>

#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/mcap_writer.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "hazmap/sources/ros_encode.hpp"
#include "ros1_bag_builder.hpp"

namespace fs = std::filesystem;
using namespace hazmap;

namespace {

void put(const fs::path& p, std::span<const std::uint8_t> b, std::uint8_t prefix = 0, bool with_prefix = false) {
  std::ofstream out(p, std::ios::binary);
  if (with_prefix) out.put(static_cast<char>(prefix));
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

LabeledCloud smallCloud(int k) {
  LabeledCloud c;
  c.enableIntensity();
  c.enableTimestamps();
  for (int i = 0; i < 12; ++i) c.push_back({1.0f + i, 0.5f * k, 0.1f * i}, static_cast<ClassId>(i % 3), 5.0f * i, 10.0 + 0.01 * i);
  return c;
}

void mcapSeeds(const fs::path& dir) {
  for (const auto [name, compression] : {std::pair{"zstd.mcap", McapCompression::Zstd}, {"lz4.mcap", McapCompression::Lz4},
                                         {"none.mcap", McapCompression::None}}) {
    McapWriterOptions options;
    options.compression = compression;
    options.chunk_size = 600;
    McapWriter w(dir / name, options);
    const auto points = w.addRosChannel("/points", "sensor_msgs/msg/PointCloud2");
    const auto odom = w.addRosChannel("/odom", "nav_msgs/msg/Odometry");
    const auto text = w.addRosChannel("/meta", "std_msgs/msg/String");
    for (int k = 0; k < 3; ++k) {
      w.write(points, 10'000'000'000 + k, encodePointCloud2(cloudToPointCloud2(smallCloud(k), {10.0, "lidar"})));
      OdometryMsg o;
      o.pose.translation().x() = k;
      w.write(odom, 9'999'000'000 + k, encodeOdometry(o));
    }
    w.write(text, 10'000'000'005, encodeString("{\"a\": 1}"));
    w.close();
  }
  std::ifstream in(dir / "none.mcap", std::ios::binary);
  std::vector<std::uint8_t> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  put(dir / "cut.mcap", std::span(bytes).first(bytes.size() * 2 / 3));
}

void ros1Seeds(const fs::path& dir) {
  const std::vector<test::Conn> conns = {{"/points", "sensor_msgs/PointCloud2"}, {"/odom", "nav_msgs/Odometry"},
                                         {"/velodyne_packets", "velodyne_msgs/VelodyneScan"}, {"/meta", "std_msgs/String"}};
  test::Ros1Out str;
  str.str("{\"lidar_mode\": \"1024x10\"}");
  const std::vector<std::vector<test::Msg>> chunks = {{{0, 10, test::ros1Cloud(10, 1)}, {1, 11, test::ros1Odometry(11, 0.5)}},
                                                      {{2, 12, test::ros1VelodyneScan(12, 1)}, {3, 9, str.b}}};
  for (const std::string c : {"none", "bz2", "lz4"}) {
    put(dir / (c + "_indexed.bag"), test::buildBag(conns, chunks, c, true));
    put(dir / (c + "_scan.bag"), test::buildBag(conns, chunks, c, false));
  }
}

void exec(sqlite3* db, const char* sql) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &err) != SQLITE_OK) throw std::runtime_error(err ? err : "sqlite3");
}

void db3Seed(const fs::path& file) {
  fs::remove(file);
  sqlite3* db = nullptr;
  if (sqlite3_open(file.c_str(), &db) != SQLITE_OK) throw std::runtime_error("cannot create " + file.string());
  exec(db, "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
           "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL);"
           "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
           "INSERT INTO topics VALUES(1,'/points','sensor_msgs/msg/PointCloud2','cdr','');"
           "INSERT INTO topics VALUES(2,'/meta','std_msgs/msg/String','cdr','');");
  sqlite3_stmt* stmt = nullptr;
  sqlite3_prepare_v2(db, "INSERT INTO messages(topic_id, timestamp, data) VALUES(?,?,?)", -1, &stmt, nullptr);
  auto insert = [&](int topic, std::int64_t t, const std::vector<std::uint8_t>& data) {
    sqlite3_bind_int(stmt, 1, topic);
    sqlite3_bind_int64(stmt, 2, t);
    sqlite3_bind_blob(stmt, 3, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
    sqlite3_step(stmt);
    sqlite3_reset(stmt);
  };
  insert(1, 20, encodePointCloud2(cloudToPointCloud2(smallCloud(1), {1.0, "l"})));
  insert(2, 10, encodeString("hello"));
  sqlite3_finalize(stmt);
  sqlite3_close(db);
}

void messageSeeds(const fs::path& dir) {
  // Selector byte: bit 0 = ROS 1, bits 1.. = decoder (0 cloud, 1 odometry, 2 image, 3 velodyne,
  // 4 packet, 5 string, 6 pose).
  put(dir / "cloud_cdr", encodePointCloud2(cloudToPointCloud2(smallCloud(0), {5.0, "l"})), 0, true);
  put(dir / "cloud_cdr_be", encodePointCloud2(cloudToPointCloud2(smallCloud(0), {5.0, "l"}), true), 0, true);
  put(dir / "cloud_ros1", test::ros1Cloud(3, 1), 1, true);
  put(dir / "odom_cdr", encodeOdometry(OdometryMsg{}), 2, true);
  put(dir / "odom_ros1", test::ros1Odometry(3, 1), 3, true);
  ImageMsg img;
  img.width = 2, img.height = 2, img.step = 4, img.encoding = "mono16", img.data.assign(8, 1);
  put(dir / "image_cdr", encodeImage(img), 4, true);
  put(dir / "velodyne_ros1", test::ros1VelodyneScan(3, 1), 7, true);
  put(dir / "string_cdr", encodeString("{}"), 10, true);
  put(dir / "pose_cdr", encodePoseStamped({1.0, "map"}, Eigen::Isometry3d::Identity()), 12, true);
}

/// fuzz_hesai's seeds: the first packets of each real Hesai bag (selector = the model's size
/// class, as fuzz_hesai.cpp reads them) and each recording's angle-correction CSV.
void hesaiSeeds(const fs::path& data, const fs::path& dir) {
  const std::pair<const char*, std::uint8_t> bags[] = {
      {"hesai-pandar40p", 0}, {"hesai-pandar64", 1}, {"hesai-qt128", 3}, {"hesai-xt32", 5}};
  for (const auto& [name, model] : bags) {
    for (const auto& e : fs::directory_iterator(data / "sensors" / name)) {
      if (e.path().extension() == ".csv") {
        std::ifstream csv(e.path(), std::ios::binary);
        const std::vector<std::uint8_t> text{std::istreambuf_iterator<char>(csv), std::istreambuf_iterator<char>()};
        put(dir / (std::string(name) + "_csv"), text, static_cast<std::uint8_t>(0x80 | model), true);
      }
      if (!e.is_directory()) continue;
      auto bag = openBag(e.path());
      BagMessage m;
      if (!bag->next(m)) continue;
      const auto scan = decodePandarScan(m.data, m.topic->serialization, e.path().string());
      std::vector<std::uint8_t> seed = {0, 0};
      for (std::size_t i = 0; i < scan.packets.size() && i < 8; ++i) {
        seed.push_back(model);
        seed.insert(seed.end(), scan.packets[i].data.begin(), scan.packets[i].data.end());
      }
      put(dir / (std::string(name) + "_packets"), seed);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: hazmap_fuzz_bag_seeds SHARED_DATA_DIR OUT_DIR\n";
    return 2;
  }
  const fs::path data = argv[1], out = argv[2];
  try {
    for (const char* d : {"mcap", "ros1_bag", "rosbag2", "ros_messages", "hesai"}) fs::create_directories(out / d);
    hesaiSeeds(data, out / "hesai");
    mcapSeeds(out / "mcap");
    ros1Seeds(out / "ros1_bag");
    db3Seed(out / "run_0.db3");
    std::ifstream db(out / "run_0.db3", std::ios::binary);
    const std::vector<std::uint8_t> db_bytes{std::istreambuf_iterator<char>(db), std::istreambuf_iterator<char>()};
    put(out / "rosbag2/db3", db_bytes, 1, true);
    const std::string yaml = "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
                             "  relative_file_paths:\n    - run_0.db3\n";
    put(out / "rosbag2/metadata", std::span(reinterpret_cast<const std::uint8_t*>(yaml.data()), yaml.size()), 0, true);
    std::ifstream real(data / "sensors/velodyne-vlp16/metadata.yaml", std::ios::binary);
    const std::vector<std::uint8_t> real_yaml{std::istreambuf_iterator<char>(real), std::istreambuf_iterator<char>()};
    put(out / "rosbag2/nebula_metadata", real_yaml, 0, true);
    messageSeeds(out / "ros_messages");
  } catch (const std::exception& e) {
    std::cerr << "hazmap_fuzz_bag_seeds: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
