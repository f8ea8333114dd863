#include "hazmap/core/error.hpp"

namespace hazmap {

void fail(const std::string& where, const std::string& what) {
  throw Error(where.empty() ? what : where + ": " + what);
}

}  // namespace hazmap
