// hazmap: LiDAR SLAM with physical-property classes. Thin subcommands over the library.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <iostream>

#include "command.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/core/memory.hpp"

namespace hazmap::cli {

std::vector<Command>& commandRegistry() {
  static std::vector<Command> registry;
  return registry;
}

int& exitCode() {
  static int code = 0;
  return code;
}

}  // namespace hazmap::cli

int main(int argc, char** argv) {
  using namespace hazmap::cli;
  hazmap::retainFreedMemory();  // frames reuse freed scratch memory instead of page-faulting it in
  CLI::App app{"hazmap — LiDAR SLAM that uses physical-property classes (heat, water, radiation)\n"
               "of every point to match scans, close loops and map hazards."};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("hazmap 0.1.0"));
  auto& registry = commandRegistry();
  std::sort(registry.begin(), registry.end(),
            [](const Command& a, const Command& b) { return a.name < b.name; });
  for (const auto& command : registry) {
    CLI::App* sub = app.add_subcommand(command.name, command.description);
    sub->option_defaults()->always_capture_default();
    command.setup(*sub);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const hazmap::Error& e) {
    std::cerr << "hazmap: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "hazmap: error: " << e.what() << "\n";
    return 1;
  }
  return exitCode();
}
