#pragma once
// Paths the tests need, compiled once in test_paths.cpp (see there why).
#include <filesystem>
#include <stdexcept>
#include <string>

namespace hazmap::test {

/// Thrown by sharedData() for a path that does not exist; GoogleTest reports it as the test's
/// failure, with the path. Not a hazmap::Error, so errorOf() and EXPECT_THROW(…, Error) do not
/// mistake it for the error under test.
struct MissingSharedData : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// HAZMAP_SHARED_DATA_DIR (../shared/data by default), unchecked.
std::filesystem::path sharedDataRoot();
/// `rel` under the shared real data; throws MissingSharedData naming the path if it is absent.
std::filesystem::path sharedData(const std::string& rel = "");
/// The source tree (the checkout these tests were built from).
std::filesystem::path sourceRoot();
/// The hazmap CLI built with these tests.
std::string cliPath();

}  // namespace hazmap::test
