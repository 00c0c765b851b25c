// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

// A progress bar on stderr for long-running subcommands: drawn only on a terminal, and only once
// the work has lasted 0.3 s (short runs print nothing), redrawn at most ten times a second.

namespace osteon::cli {

class ProgressBar {
 public:
  /// `label` is printed before the bar; `unit` after the count ("samples", "parts").
  ProgressBar(std::string label, std::string unit, uint64_t total);
  /// Clears the line when the bar was drawn and not finished.
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  void update(uint64_t done);
  /// Draws the full bar with the elapsed time and ends the line (when the bar was ever drawn, or
  /// `always` and stderr is a terminal), so that stages stack up one line each.
  void finish(bool always = false);

 private:
  void draw(uint64_t done, bool final);

  using Clock = std::chrono::steady_clock;
  std::string label_;
  std::string unit_;
  uint64_t total_;
  bool enabled_;
  bool drawn_ = false;
  bool finished_ = false;
  Clock::time_point start_ = Clock::now();
  Clock::time_point last_ = start_;
};

}  // namespace osteon::cli
