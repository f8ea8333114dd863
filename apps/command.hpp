#pragma once
// Subcommands register themselves: each apps/cmd_<name>.cpp defines a static RegisterCommand, so
// adding a subcommand never touches main.cpp. A command's setup adds its options to the CLI11
// sub-app and installs a callback; the callback throws hazmap::Error on bad input.
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace hazmap::cli {

struct Command {
  std::string name;
  std::string description;
  std::function<void(CLI::App&)> setup;
};

std::vector<Command>& commandRegistry();

struct RegisterCommand {
  explicit RegisterCommand(Command command) { commandRegistry().push_back(std::move(command)); }
};

/// Process exit code requested by a command (0 unless a command sets it).
int& exitCode();

}  // namespace hazmap::cli
