// SPDX-License-Identifier: Apache-2.0
#include <signal.h>

#include <cstdio>
#include <ctime>
#include <memory>
#include <mutex>
#include <string>

#include "cli.hpp"
#include "serve.hpp"

// osteon serve DIR [--port 8080] [--host 127.0.0.1] [--threads N] [--max-connections N]
//                  [--max-per-client N] [--header-timeout S] [--idle-timeout S]
// Serves a package folder (what `osteon pack` writes) over HTTP until SIGINT or SIGTERM; prints the
// URL on stdout and one line per request on stderr.

namespace osteon::cli {

namespace {

int run_serve(const ServeOptions& given) {
  ServeOptions options = given;
  auto log_mutex = std::make_shared<std::mutex>();
  options.log = [log_mutex](const std::string& line) {
    std::lock_guard<std::mutex> lock(*log_mutex);
    std::fprintf(stderr, "%s\n", line.c_str());
  };
  // SIGINT and SIGTERM are blocked before the worker threads exist (they inherit the mask), and
  // this thread waits for them, so the server stops from ordinary code, not a signal handler.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  FileServer server;
  const Status started = server.start(options);
  if (!started.ok()) return fail(started);
  const bool v6 = options.host.find(':') != std::string::npos;
  std::printf("osteon: serving %s at http://%s%s%s:%d/ (Ctrl-C stops)\n", options.root.c_str(),
              v6 ? "[" : "", options.host.c_str(), v6 ? "]" : "", server.port());
  std::fflush(stdout);

  const timespec tick{0, 200 * 1000 * 1000};
  int signal_number = -1;
  while (server.running()) {
    signal_number = sigtimedwait(&stop_signals, nullptr, &tick);
    if (signal_number == SIGINT || signal_number == SIGTERM) break;
  }
  server.stop();
  if (signal_number == SIGINT || signal_number == SIGTERM) {
    std::fprintf(stderr, "osteon: stopped (%s)\n", signal_number == SIGINT ? "SIGINT" : "SIGTERM");
    return kExitOk;
  }
  return fail("serve: the server stopped unexpectedly");
}

}  // namespace

void register_serve(CLI::App& app, std::function<int()>* run) {
  auto options = std::make_shared<ServeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "serve", "Serve a package folder over HTTP (MIME types, ranges, ETags, cache headers)");
  cmd->add_option("dir", options->root, "the package folder (osteon pack -o DIR)")->required();
  cmd->add_option("--port", options->port, "TCP port; 0 picks a free one (default 8080)")
      ->check(CLI::Range(0, 65535));
  cmd->add_option("--host", options->host,
                  "address to listen on (default 127.0.0.1: this machine only)");
  cmd->add_option("--threads", options->threads,
                  "event-loop (epoll) threads; no connection holds one (default 4)")
      ->check(CLI::Range(1, 256));
  cmd->add_option("--max-connections", options->max_connections,
                  "connections served at once; a few more are answered 503 (default 2048)")
      ->check(CLI::Range(1, 1000000));
  cmd->add_option("--max-per-client", options->max_per_client,
                  "connections from one address at once; 0: no limit (default: none on "
                  "loopback, 64 otherwise)")
      ->check(CLI::Range(0, 1000000));
  cmd->add_option("--header-timeout", options->header_timeout_seconds,
                  "seconds a request head may take to arrive, whatever its pace (default 5)")
      ->check(CLI::Range(1, 3600));
  cmd->add_option("--idle-timeout", options->idle_timeout_seconds,
                  "seconds a connection may move no byte either way before it is closed (default 5)")
      ->check(CLI::Range(1, 3600));
  cmd->callback([options, run] { *run = [options] { return run_serve(*options); }; });
}

}  // namespace osteon::cli
