// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <time.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "osteon/io.hpp"

// What a benchmark needs to put its table into docs/BENCHMARKS.md: replace its own "## ..."
// section and leave the others as they are, name the machine it ran on, format its numbers, and
// time on a shared machine.

namespace osteon_bench {

/// Replaces (or appends) the section headed `heading` ("## Title") in the Markdown file at
/// `path`: from the heading to the next "## " heading. False when the file cannot be written.
inline bool write_section(const std::filesystem::path& path, const std::string& heading,
                          const std::string& body) {
  std::string text;
  {
    std::ifstream in(path);
    if (in) text.assign(std::istreambuf_iterator<char>(in), {});
  }
  if (text.empty()) {
    text = "# Benchmarks\n\nProduced by the programs in bench/; see bench/README.md.\n";
  }
  std::string section = heading + "\n\n" + body;
  size_t start = text.find(heading + "\n");
  if (start == std::string::npos) {
    if (text.back() != '\n') text += "\n";
    text += "\n" + section;
  } else {
    size_t end = text.find("\n## ", start + heading.size());
    text.replace(start, end == std::string::npos ? std::string::npos : end + 1 - start,
                 end == std::string::npos ? section : section + "\n");
  }
  std::filesystem::path parent = path.parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  return osteon::write_file_atomic(path.string(), text.data(), text.size()).ok();
}

/// The CPU's model name from /proc/cpuinfo, or "unknown CPU".
inline std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      size_t colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  }
  return "unknown CPU";
}

/// `value` with `decimals` digits after the point.
inline std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

/// `value` with `digits` significant digits (%g).
inline std::string sig(double value, int digits = 6) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*g", digits, value);
  return text;
}

/// 1234567 -> "1,234,567".
inline std::string grouped(uint64_t value) {
  const std::string digits = std::to_string(value);
  std::string out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

/// This thread's CPU time in seconds: a run preempted on a shared machine does not count the
/// other work.
inline double thread_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// Wall-clock milliseconds since `start`.
inline double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace osteon_bench
