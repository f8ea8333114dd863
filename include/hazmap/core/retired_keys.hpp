#pragma once
// Configuration keys of experiments that were measured and not adopted (issue 37): the table
// lives in src/core/retired_keys.cpp; the unknown-key error (config_fields.cpp) quotes it.
#include <string>

namespace hazmap::config_detail {

/// For the dotted path of a retired key ("odometry.slip_guess_yaw", or its tail as a command that
/// reads one section spells it): "retired: measured and not adopted, see docs/history/…"; empty
/// for any other key.
std::string retiredKeyNote(const std::string& path);

/// Markdown for docs/configuration.md: the keys that moved (old → new path) and the keys that
/// became named constants (key → file), from the same table the errors quote.
std::string movedAndConstantKeysMarkdown();

}  // namespace hazmap::config_detail
