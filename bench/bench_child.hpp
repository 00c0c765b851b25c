// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <functional>
#include <string>

// Running one measurement in its own process, so that its peak resident memory is its own: the
// child runs `work` and sends what it returns (JSON, say) back through a pipe.

namespace osteon_bench {

/// Runs `work` in a forked child and returns the text it produced ("" when the child died);
/// `usage`, when given, gets the child's resource usage (ru_maxrss: its peak, in KiB).
inline std::string run_in_child(const std::function<std::string()>& work, rusage* usage = nullptr) {
  int fds[2];
  if (pipe(fds) != 0) return {};
  std::fflush(nullptr);  // or the child would print this process's pending output again
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    const std::string text = work();
    std::fflush(nullptr);  // _exit does not flush what the child printed
    size_t sent = 0;
    while (sent < text.size()) {
      const ssize_t n = write(fds[1], text.data() + sent, text.size() - sent);
      if (n <= 0) break;
      sent += size_t(n);
    }
    _exit(0);
  }
  close(fds[1]);
  std::string text;
  char buffer[4096];
  ssize_t n;
  while ((n = read(fds[0], buffer, sizeof(buffer))) > 0) text.append(buffer, size_t(n));
  close(fds[0]);
  int status = 0;
  rusage child{};
  wait4(pid, &status, 0, &child);
  if (usage != nullptr) *usage = child;
  return text;
}

}  // namespace osteon_bench
