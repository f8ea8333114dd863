// The only test file that knows the machine's paths (shared data, source tree, CLI): the test
// sources carry no absolute path on their command line, so ccache shares them across checkouts
// and a new HAZMAP_SHARED_DATA_DIR rebuilds this file alone.
#include "test_paths.hpp"

#include <stdexcept>

namespace hazmap::test {

std::filesystem::path sharedDataRoot() { return HAZMAP_SHARED_DATA_DIR; }
std::filesystem::path sourceRoot() { return HAZMAP_SOURCE_DIR; }
std::string cliPath() { return HAZMAP_CLI; }

std::filesystem::path sharedData(const std::string& rel) {
  const std::filesystem::path path = sharedDataRoot() / rel;
  std::error_code ec;
  // Thrown, not ADD_FAILURE'd: the test stops here with the path in its failure instead of going
  // on with an empty read (a missing file used to crash the MCAP tests).
  if (!std::filesystem::exists(path, ec))
    throw MissingSharedData("shared test data not found: " + path.string() +
                            " (the ../shared/data checkout; configure with -DHAZMAP_SHARED_DATA_DIR=<dir>)");
  return path;
}

}  // namespace hazmap::test
