// io: every bad-input case gives one line naming the file and the problem — in the library and
// through the CLI (non-zero exit) — never a crash, a huge allocation or a half-written output.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/cloud_file.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/io/transform_file.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

void writeBytes(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

template <typename T>
std::string bytesOf(const std::vector<T>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

/// `fn` must throw hazmap::Error with a one-line message that starts with the file and mentions
/// `phrase`.
void expectFileError(const std::function<void()>& fn, const fs::path& file, const std::string& phrase) {
  try {
    fn();
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(file.string() + ": ", 0), 0u) << "message does not start with the file: " << msg;
    EXPECT_NE(msg.find(phrase), std::string::npos) << "missing '" << phrase << "' in: " << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "not one line: " << msg;
    return;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "threw a non-hazmap exception: " << e.what();
    return;
  }
  ADD_FAILURE() << "no error for " << file << " (expected '" << phrase << "')";
}

/// The CLI (`hazmap info FILE`) exits 1 with exactly one line "hazmap: error: FILE: ...phrase...".
void expectCliError(const fs::path& file, const std::string& phrase, const std::string& command = "info") {
  const auto r = test::runCli(command + " '" + file.string() + "'");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_EQ(r.output.rfind("hazmap: error: " + file.string() + ": ", 0), 0u) << r.output;
  EXPECT_NE(r.output.find(phrase), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
}

/// Both the library and the CLI reject `file` with `phrase`.
void expectRejected(const fs::path& file, const std::string& phrase) {
  expectFileError([&] { (void)readCloud(file); }, file, phrase);
  expectCliError(file, phrase);
}

const std::string kPcdHead =
    "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
    "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\n";

std::string pcdWith(const std::string& from, const std::string& to, const std::string& data = "DATA ascii\n1 2 3 4\n5 6 7 8\n") {
  std::string h = kPcdHead;
  if (!from.empty()) {
    const auto at = h.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    h.replace(at, from.size(), to);
  }
  return h + data;
}

const std::string kPlyHead =
    "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
    "property float intensity\nend_header\n";

std::string plyWith(const std::string& from, const std::string& to, const std::string& body = "1 2 3 4\n5 6 7 8\n") {
  std::string h = kPlyHead;
  if (!from.empty()) {
    const auto at = h.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    h.replace(at, from.size(), to);
  }
  return h + body;
}

}  // namespace

TEST(IoErrors, MissingFiles) {
  const auto dir = test::scratchDir();
  for (const char* name : {"none.bin", "none.pcd", "none.ply"}) expectRejected(dir / name, "file not found");
  expectFileError([&] { (void)readSemanticKittiLabels(dir / "none.label"); }, dir / "none.label", "file not found");
  expectFileError([&] { (void)readKittiTrajectory(dir / "poses.txt"); }, dir / "poses.txt", "file not found");
  expectFileError([&] { (void)readTrajectoryAuto(dir / "t.txt"); }, dir / "t.txt", "file not found");
  expectFileError([&] { (void)readPlyMesh(dir / "m.ply"); }, dir / "m.ply", "file not found");
  expectFileError([&] { (void)Sequence::open(dir / "seq"); }, dir / "seq", "not found");
  expectFileError([&] { (void)Sequence::open(dir); }, dir, "no velodyne/ folder");
  // A label file named explicitly but missing.
  writeBytes(dir / "a.bin", bytesOf(std::vector<float>{1, 2, 3, 4}));
  expectFileError([&] { (void)readCloud(dir / "a.bin", ClassTable::defaults(), nullptr, dir / "x.label"); },
                  dir / "x.label", "file not found");
}

TEST(IoErrors, UnknownExtension) {
  const auto dir = test::scratchDir();
  writeBytes(dir / "cloud.xyz", "1 2 3\n");
  expectRejected(dir / "cloud.xyz", "unknown cloud format '.xyz'");
  expectFileError([&] { writeCloud(dir / "out.las", LabeledCloud{}); }, dir / "out.las", "unknown cloud format");
}

TEST(IoErrors, TruncatedBinaries) {
  const auto dir = test::scratchDir();
  std::string bin = bytesOf(std::vector<float>{1, 2, 3, 4, 5, 6, 7, 8});
  writeBytes(dir / "t.bin", bin.substr(0, 27));
  expectRejected(dir / "t.bin", "not a multiple of 16");
  writeBytes(dir / "t.label", std::string(6, '\0'));
  expectFileError([&] { (void)readSemanticKittiLabels(dir / "t.label"); }, dir / "t.label", "not a multiple of 4");

  // Binary PCD: header says 2 points (32 bytes), 20 bytes follow.
  writeBytes(dir / "t.pcd", pcdWith("", "", "DATA binary\n" + bin.substr(0, 20)));
  expectRejected(dir / "t.pcd", "truncated");
  // binary_compressed: size words missing / block shorter than declared.
  writeBytes(dir / "c1.pcd", pcdWith("", "", "DATA binary_compressed\n\x05"));
  expectRejected(dir / "c1.pcd", "truncated");
  const std::uint32_t sizes[2] = {100, 32};
  writeBytes(dir / "c2.pcd", pcdWith("", "", "DATA binary_compressed\n" + std::string(reinterpret_cast<const char*>(sizes), 8) + "abc"));
  expectRejected(dir / "c2.pcd", "truncated");
  // Corrupt LZF stream of the right size.
  const std::uint32_t sizes3[2] = {4, 32};
  writeBytes(dir / "c3.pcd", pcdWith("", "", "DATA binary_compressed\n" + std::string(reinterpret_cast<const char*>(sizes3), 8) + "\x3f\xff\xff\xff"));
  expectRejected(dir / "c3.pcd", "corrupt");

  // Binary PLY cut inside the vertex element.
  std::string ply = plyWith("format ascii 1.0", "format binary_little_endian 1.0", bin.substr(0, 30));
  writeBytes(dir / "t.ply", ply);
  expectRejected(dir / "t.ply", "truncated");
  // ASCII PLY with fewer lines than vertices.
  writeBytes(dir / "ta.ply", plyWith("", "", "1 2 3 4\n"));
  expectRejected(dir / "ta.ply", "truncated");
  // ASCII PCD with fewer points than declared.
  writeBytes(dir / "ta.pcd", pcdWith("", "", "DATA ascii\n1 2 3 4\n"));
  expectRejected(dir / "ta.pcd", "truncated");
}

TEST(IoErrors, LabelCountDiffersFromPointCount) {
  const auto dir = test::scratchDir() / "seq";
  fs::create_directories(dir / "velodyne");
  fs::create_directories(dir / "labels");
  writeBytes(dir / "velodyne/000000.bin", bytesOf(std::vector<float>{1, 2, 3, 4, 5, 6, 7, 8}));
  writeBytes(dir / "labels/000000.label", bytesOf(std::vector<std::uint32_t>{1, 2, 3}));
  const auto label = dir / "labels/000000.label";
  expectFileError([&] { (void)readCloud(dir / "velodyne/000000.bin"); }, label, "has 3 labels but");
  expectFileError([&] { (void)Sequence::open(dir).frame(0); }, label, "2 points");
  // The CLI reads the .bin, finds labels/ automatically and names the label file.
  const auto r = test::runCli("info '" + (dir / "velodyne/000000.bin").string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.output, "hazmap: error: " + label.string() + ": has 3 labels but " +
                          (dir / "velodyne/000000.bin").string() + " has 2 points\n");
}

TEST(IoErrors, PcdHeaderErrors) {
  const auto dir = test::scratchDir();
  const std::vector<std::tuple<std::string, std::string, std::string, std::string>> cases = {
      {"unknown_type", "TYPE F F F F", "TYPE F F F X", "unknown TYPE 'X'"},
      {"bad_size", "SIZE 4 4 4 4", "SIZE 4 4 4 3", "unsupported SIZE 3"},
      {"missing_field", "FIELDS x y z intensity", "FIELDS x y q intensity", "missing field 'z'"},
      {"size_count", "SIZE 4 4 4 4", "SIZE 4 4 4", "SIZE has 3 entries but FIELDS has 4"},
      {"type_count", "TYPE F F F F", "TYPE F F F F F", "TYPE has 5 entries"},
      {"count_count", "COUNT 1 1 1 1", "COUNT 1 1", "COUNT has 2 entries"},
      {"points_mismatch", "POINTS 2", "POINTS 3", "POINTS 3 differs from WIDTH"},
      {"bad_width", "WIDTH 2", "WIDTH two", "WIDTH needs one non-negative integer"},
      {"unknown_key", "VIEWPOINT", "VIEWPORT", "unknown header entry 'VIEWPORT'"},
      {"huge_count", "COUNT 1 1 1 1", "COUNT 1 1 1 1000000000000", "COUNT 1000000000000 out of range"},
  };
  for (const auto& [name, from, to, phrase] : cases) {
    SCOPED_TRACE(name);
    const auto file = dir / (name + ".pcd");
    writeBytes(file, pcdWith(from, to));
    expectRejected(file, phrase);
  }
  writeBytes(dir / "bad_data.pcd", pcdWith("", "", "DATA binary_zipped\n"));
  expectRejected(dir / "bad_data.pcd", "bad DATA kind 'binary_zipped'");
  writeBytes(dir / "no_data.pcd", kPcdHead);
  expectRejected(dir / "no_data.pcd", "no DATA line");
  writeBytes(dir / "garbage.pcd", std::string("\x89PNG\r\n\x1a\n", 8) + std::string(100, 'x'));
  expectRejected(dir / "garbage.pcd", "unknown header entry");
}

TEST(IoErrors, PlyHeaderErrors) {
  const auto dir = test::scratchDir();
  const std::vector<std::tuple<std::string, std::string, std::string, std::string>> cases = {
      {"unknown_type", "property float intensity", "property float16 intensity", "unknown type 'float16'"},
      {"missing_field", "property float y", "property float w", "missing vertex property 'y'"},
      {"bad_format", "format ascii 1.0", "format binary_middle_endian 1.0", "unknown format 'binary_middle_endian'"},
      {"no_magic", "ply\n", "plx\n", "not a PLY file"},
      {"no_end", "end_header\n", "", "end_header"},
      {"no_format", "format ascii 1.0\n", "", "no format line"},
      {"bad_element", "element vertex 2", "element vertex -2", "element line needs"},
      {"list_xyz", "property float x", "property list uchar float x", "vertex property 'x' is a list"},
      {"no_vertex", "element vertex 2", "element point 2", "no 'vertex' element"},
  };
  for (const auto& [name, from, to, phrase] : cases) {
    SCOPED_TRACE(name);
    const auto file = dir / (name + ".ply");
    writeBytes(file, plyWith(from, to));
    expectRejected(file, phrase);
  }
  // Count mismatch: an ascii row with the wrong number of values.
  writeBytes(dir / "row.ply", plyWith("", "", "1 2 3 4\n5 6 7\n"));
  expectRejected(dir / "row.ply", "line 10: too few values");
  writeBytes(dir / "row2.ply", plyWith("", "", "1 2 3 4 9\n5 6 7 8\n"));
  expectRejected(dir / "row2.ply", "line 9: expected 4 values for element 'vertex', found 5");
  // Mesh: a face refers to a vertex that does not exist.
  writeBytes(dir / "mesh.ply",
             "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  expectFileError([&] { (void)readPlyMesh(dir / "mesh.ply"); }, dir / "mesh.ply", "refers to vertex 7");
}

TEST(IoErrors, NonNumericText) {
  const auto dir = test::scratchDir();
  writeBytes(dir / "n.pcd", pcdWith("", "", "DATA ascii\n1 2 3 4\n5 abc 7 8\n"));
  expectRejected(dir / "n.pcd", "line 13: 'abc' is not a number");
  writeBytes(dir / "n.ply", plyWith("", "", "1 2 3 4\n5 6 7 0x1F\n"));
  expectRejected(dir / "n.ply", "line 10: '0x1F' is not a number");
  writeBytes(dir / "k.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 one 0\n");
  expectFileError([&] { (void)readKittiTrajectory(dir / "k.txt"); }, dir / "k.txt", "line 2: 'one' is not a number");
  writeBytes(dir / "t.txt", "# tum\n0.1 1 2 3 0 0 0 1\n0.2 1 2 3 0 0 0 1x\n");
  expectFileError([&] { (void)readTumTrajectory(dir / "t.txt"); }, dir / "t.txt", "line 3: '1x' is not a number");
  writeBytes(dir / "w.txt", "1 2 3\n");
  expectFileError([&] { (void)readTrajectoryAuto(dir / "w.txt"); }, dir / "w.txt", "expected 12 numbers (KITTI) or 8 (TUM), found 3");
  writeBytes(dir / "r.txt", "1 0 0 0 0 1 0 0 0 0 5 0\n");
  expectFileError([&] { (void)readKittiTrajectory(dir / "r.txt"); }, dir / "r.txt", "not a rotation");
  writeBytes(dir / "q.txt", "0 1 2 3 0 0 0 0\n");
  expectFileError([&] { (void)readTumTrajectory(dir / "q.txt"); }, dir / "q.txt", "zero length");
  // A PCD label that is not a label.
  writeBytes(dir / "l.pcd",
             "VERSION 0.7\nFIELDS x y z label\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 1\nHEIGHT 1\n"
             "POINTS 1\nDATA ascii\n1 2 3 -4\n");
  expectRejected(dir / "l.pcd", "label -4");
}

TEST(IoErrors, AbsurdSizesDoNotAllocate) {
  const auto dir = test::scratchDir();
  const std::string tera = "1000000000000";
  for (const char* data : {"DATA binary\n", "DATA ascii\n"}) {
    SCOPED_TRACE(data);
    const auto file = dir / "huge.pcd";
    writeBytes(file, pcdWith("WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2",
                             "WIDTH " + tera + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + tera,
                             std::string(data) + "1 2 3 4\n"));
    expectRejected(file, "claims 1000000000000 points");
  }
  // WIDTH × HEIGHT overflowing 64 bits.
  writeBytes(dir / "ovf.pcd", pcdWith("WIDTH 2\nHEIGHT 1", "WIDTH 18446744073709551615\nHEIGHT 3"));
  expectRejected(dir / "ovf.pcd", "overflows");
  // binary_compressed claiming 4 GB from 8 bytes.
  const std::uint32_t sizes[2] = {8, 4000000000u};
  writeBytes(dir / "zip.pcd", pcdWith("WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2",
                                      "WIDTH 250000000\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 250000000",
                                      "DATA binary_compressed\n" + std::string(reinterpret_cast<const char*>(sizes), 8) + "12345678"));
  expectRejected(dir / "zip.pcd", "corrupt");
  for (const char* fmt : {"format ascii 1.0", "format binary_little_endian 1.0"}) {
    SCOPED_TRACE(fmt);
    writeBytes(dir / "huge.ply", plyWith("element vertex 2", "element vertex " + tera, "1 2 3 4\n"));
    std::string text = readTextFile(dir / "huge.ply");
    text.replace(text.find("format ascii 1.0"), 16, fmt);
    writeBytes(dir / "huge.ply", text);
    expectRejected(dir / "huge.ply", "claims 1000000000000 items");
  }
  // A binary list claiming 4 billion entries.
  std::string mesh = "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n";
  const std::uint32_t n = 4000000000u;
  mesh.append(reinterpret_cast<const char*>(&n), 4);
  writeBytes(dir / "list.ply", mesh);
  expectFileError([&] { (void)readPlyMesh(dir / "list.ply"); }, dir / "list.ply", "truncated");
}

TEST(IoErrors, NaNPointsAreDroppedCountedAndReportedByInfo) {
  const auto dir = test::scratchDir();
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  writeBytes(dir / "n.bin", bytesOf(std::vector<float>{1, 2, 3, 0, nan, 1, 1, 0, 4, 5, 6, 0, 1, inf, 1, 0, 7, 8, 9, nan}));
  ReadStats st;
  const auto c = readCloud(dir / "n.bin", ClassTable::defaults(), &st);
  EXPECT_EQ(c.size(), 2u);
  EXPECT_EQ(st.points_in_file, 5u);
  EXPECT_EQ(st.dropped_non_finite, 3u);
  for (const auto& p : c.points) EXPECT_TRUE(p.allFinite());
  const auto r = test::runCli("info --json '" + (dir / "n.bin").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"dropped_non_finite\": 3"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"points\": 2"), std::string::npos) << r.output;
  // Converting writes only the finite points.
  const auto conv = test::runCli("convert '" + (dir / "n.bin").string() + "' '" + (dir / "n.pcd").string() + "'");
  ASSERT_EQ(conv.exit_code, 0) << conv.output;
  EXPECT_EQ(readPcd(dir / "n.pcd").size(), 2u);
}

TEST(IoErrors, SequenceProblemsNameTheFile) {
  const auto dir = test::scratchDir();
  fs::create_directories(dir / "velodyne");
  writeKittiBin(dir / "velodyne/000000.bin", [] {
    LabeledCloud c;
    c.push_back({1, 2, 3});
    return c;
  }());
  writeBytes(dir / "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n");
  expectFileError([&] { (void)Sequence::open(dir); }, dir / "poses.txt", "has 2 poses but the sequence has 1 scans");
  fs::remove(dir / "poses.txt");
  writeBytes(dir / "hazmap.yaml", "class_table: [unclosed\n");
  expectFileError([&] { (void)Sequence::open(dir); }, dir / "hazmap.yaml", "invalid YAML");
  writeBytes(dir / "hazmap.yaml", "class_table: {classes: [{id: 0}]}\n");
  expectFileError([&] { (void)Sequence::open(dir); }, dir / "hazmap.yaml", "needs at least 'id' and 'name'");
  const auto r = test::runCli("info '" + dir.string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.output, "hazmap: error: " + (dir / "hazmap.yaml").string() +
                          ": class_table: each class needs at least 'id' and 'name'\n");
}

TEST(IoErrors, WritersNeverLeaveHalfWrittenFiles) {
  const auto dir = test::scratchDir();
  // Into a folder that does not exist: error names the file, nothing created.
  LabeledCloud c;
  c.push_back({1, 2, 3}, 1);
  for (const char* name : {"no/a.pcd", "no/a.ply", "no/a.bin"})
    expectFileError([&] { writeCloud(dir / name, c); }, dir / name, "output folder does not exist");
  EXPECT_FALSE(fs::exists(dir / "no"));
  // An inconsistent cloud is rejected before anything is written; an existing file stays intact.
  writeBytes(dir / "keep.pcd", "old contents");
  LabeledCloud bad = c;
  bad.intensity = {1.0f, 2.0f};
  for (const char* name : {"keep.pcd", "keep.ply", "keep.bin"})
    expectFileError([&] { writeCloud(dir / name, bad); }, dir / name, "intensity count 2 differs");
  EXPECT_EQ(readTextFile(dir / "keep.pcd"), "old contents");
  EXPECT_FALSE(fs::exists(dir / "keep.ply"));
  // A failing convert leaves no output and no temporary files.
  writeBytes(dir / "broken.pcd", pcdWith("TYPE F F F F", "TYPE F F F Q"));
  const auto r = test::runCli("convert '" + (dir / "broken.pcd").string() + "' '" + (dir / "out.ply").string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.output.rfind("hazmap: error: " + (dir / "broken.pcd").string(), 0), 0u) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out.ply"));
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
}

TEST(IoCli, ConvertKeepsClassesAndIntensityAcrossFormats) {
  const auto dir = test::scratchDir();
  const auto bin = test::sharedData("kitti-semantic-sample/velodyne/000000.bin");
  const auto reference = readCloud(bin, ClassTable::semanticKitti());
  auto r = test::runCli("convert --classes semantic-kitti '" + bin.string() + "' '" + (dir / "a.pcd").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::runCli("convert '" + (dir / "a.pcd").string() + "' '" + (dir / "b.ply").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::runCli("convert '" + (dir / "b.ply").string() + "' '" + (dir / "c.bin").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_TRUE(fs::exists(dir / "c.label"));
  r = test::runCli("convert --pcd-encoding binary_compressed '" + (dir / "c.bin").string() + "' '" +
                   (dir / "d.pcd").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto back = readCloud(dir / "d.pcd");
  ASSERT_EQ(back.size(), reference.size());
  EXPECT_EQ(back.points, reference.points);
  EXPECT_EQ(back.classes, reference.classes);
  EXPECT_EQ(back.intensity, reference.intensity);
  // info reports the class histogram of the labelled scan.
  r = test::runCli("info '" + (dir / "d.pcd").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("points: 124668"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("radiation (radiation)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("fields: x y z intensity label"), std::string::npos) << r.output;
}

TEST(IoCli, InfoOnASequenceDirectory) {
  const auto r = test::runCli("info --json --classes semantic-kitti '" +
                              test::sharedData("kitti-semantic-sample").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"kind\": \"sequence\""), std::string::npos);
  EXPECT_NE(r.output.find("\"frames\": 6"), std::string::npos);
  EXPECT_NE(r.output.find("\"points\": 745811"), std::string::npos);  // sum of the six scans
  EXPECT_NE(r.output.find("\"file\": \"000005.bin\""), std::string::npos);
}

TEST(IoErrors, ClassTableWithRawLabelsNeedsAnExistingUnmappedClass) {
  // Found by fuzz_class_table: this table parsed, but hazmap could not read back what it wrote.
  const std::string yaml =
      "classes:\n  - {id: 5, name: none}\n  - {id: 1, name: heat, kind: heat}\nraw_labels: {80: 1}\n";
  expectFileError([&] { (void)ClassTable::fromYamlString(yaml, "t.yaml"); }, "t.yaml",
                  "unmapped_class 0 is not a class in the table");
  const auto ok = ClassTable::fromYamlString(yaml + "unmapped_class: 5\n", "t.yaml");
  EXPECT_EQ(ok.mapRaw(12), 5);
  EXPECT_EQ(ClassTable::fromYamlString(ok.toYamlString(), "again").mapRaw(12), 5);
}

// The scan pair's reference transform and hazmap register's printed result: 4×4 or 3×4, anything
// else a one-line error naming the file.
TEST(IoErrors, TransformFiles) {
  const fs::path dir = test::scratchDir();
  const fs::path four = dir / "four.txt", three = dir / "three.txt";
  writeTextAtomically(four, "0 -1 0 1.5\n1 0 0 -2\n0 0 1 0.25\n0 0 0 1\n");
  writeTextAtomically(three, "0 -1 0 1.5 1 0 0 -2 0 0 1 0.25");
  for (const fs::path& f : {four, three}) {
    const Eigen::Isometry3d T = readTransformFile(f);
    EXPECT_NEAR((T.translation() - Eigen::Vector3d(1.5, -2, 0.25)).norm(), 0.0, 1e-12) << f;
    EXPECT_NEAR(T.linear()(1, 0), 1.0, 1e-12) << f;
  }
  const Eigen::Isometry3d reference = readTransformFile(test::sharedData("scan-pair/relative.txt"));
  EXPECT_GT(reference.translation().norm(), 0.1);  // the pair's two scans are not at one place
  const auto rejects = [&](const std::string& text, const std::string& phrase) {
    const fs::path f = dir / "bad.txt";
    writeTextAtomically(f, text);
    expectFileError([&] { (void)readTransformFile(f); }, f, phrase);
  };
  rejects("1 0 0 0 0 1 0 0 0 0 1 0 0 0 0", "found 15");
  rejects("1 0 0 0 0 1 0 0 0 0 1 x", "not a number: 'x'");
  rejects("1 0 0 0 0 1 0 0 0 0 1 2e", "not a number");
  rejects("1 0 0 0 0 1 0 0 0 0 1 nan", "non-finite");
  rejects("1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1", "last row");
  rejects("2 0 0 0 0 1 0 0 0 0 1 0", "not a rotation");
  rejects("-1 0 0 0 0 1 0 0 0 0 1 0", "not a rotation");  // a reflection
  expectFileError([&] { (void)readTransformFile(dir / "missing.txt"); }, dir / "missing.txt", "");
}
