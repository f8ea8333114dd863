#pragma once
// One exception type for every user-facing failure. The message is a single line that names the
// file (or the parameter) and what is wrong with it; the CLI prints it and exits non-zero.
#include <stdexcept>
#include <string>

namespace hazmap {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Throws Error("<where>: <what>").
[[noreturn]] void fail(const std::string& where, const std::string& what);

}  // namespace hazmap
