// SPDX-License-Identifier: Apache-2.0
#include "progress.hpp"

#include <algorithm>
#include <cstdio>
#include <utility>

#include "cli.hpp"

namespace osteon::cli {

ProgressBar::ProgressBar(std::string label, std::string unit, uint64_t total)
    : label_(std::move(label)),
      unit_(std::move(unit)),
      total_(std::max<uint64_t>(total, 1)),
      enabled_(stderr_is_tty()) {}

ProgressBar::~ProgressBar() {
  if (drawn_ && !finished_) std::fprintf(stderr, "\r\033[K");
}

void ProgressBar::update(uint64_t done) {
  if (!enabled_ || finished_) return;
  const auto now = Clock::now();
  if (now - start_ < std::chrono::milliseconds(300)) return;
  if (drawn_ && now - last_ < std::chrono::milliseconds(100)) return;
  last_ = now;
  draw(done, false);
}

void ProgressBar::finish(bool always) {
  if (!enabled_ || finished_) return;
  if (drawn_ || always) {
    draw(total_, true);
    std::fputc('\n', stderr);
  }
  finished_ = true;
}

void ProgressBar::draw(uint64_t done, bool final) {
  drawn_ = true;
  const double fraction = std::min(1.0, double(done) / double(total_));
  const int filled = static_cast<int>(fraction * 30);
  const double seconds = std::chrono::duration<double>(Clock::now() - start_).count();
  std::fprintf(stderr, "\r\033[K%-10s [%s%s] %3d%% %llu/%llu %s", label_.c_str(),
               std::string(filled, '#').c_str(), std::string(30 - filled, '.').c_str(),
               static_cast<int>(fraction * 100), static_cast<unsigned long long>(done),
               static_cast<unsigned long long>(total_), unit_.c_str());
  if (final) std::fprintf(stderr, " %.1f s", seconds);
  std::fflush(stderr);
}

}  // namespace osteon::cli
