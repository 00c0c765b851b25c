// SPDX-License-Identifier: Apache-2.0
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include "serve_client.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>

#include "bench_markdown.hpp"

// osteon serve under slow, numerous, vanishing and hostile clients, with nginx serving the same
// folder in the same run as the yardstick. Loopback only; every loop is bounded in count and time.
//
// Phases, each against `osteon serve` (a child process, so its resident memory is its own) and
// then nginx (Debian's, started on a loopback port with a temporary prefix and configuration):
//   slowloris  N connections from 127.0.0.1 (the normal client's own address) that send a
//              request line, then a header line every 2 s, never ending the head; a connection
//              the server closes is replaced at once. A normal client asks 20 times a second,
//              each request on a fresh connection with 3 s timeouts: latency and failures.
//   load       C keep-alive clients loop over every file of the package; requests per second,
//              MB/s, failures (each body checked against the file), and the normal client again.
//   vanish     (osteon only) C clients ask for the largest file and vanish after 16 KiB, half
//              with a reset; then the hostile requests of tests/serve_abuse_test.cpp; then a
//              check that every file is still served right.
// The server's RSS (VmRSS) is read at start, every second, and at the end.

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

/// Resident memory of `pid` and of its children (nginx's workers are its master's), in KiB.
long rss_kib(pid_t pid) {
  long total = -1;
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) total = std::atol(line.c_str() + 6);
  }
  if (total < 0) return -1;
  std::ifstream children("/proc/" + std::to_string(pid) + "/task/" + std::to_string(pid) +
                         "/children");
  pid_t child = 0;
  while (children >> child) {
    const long kib = rss_kib(child);
    if (kib > 0) total += kib;
  }
  return total;
}


int free_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  close(fd);
  return ntohs(a.sin_port);
}

bool wait_until_serving(int port, double seconds) {
  const auto until = Clock::now() + std::chrono::duration<double>(seconds);
  while (Clock::now() < until) {
    const int fd = osteon::test::connect_loopback(port);
    if (fd >= 0) {
      close(fd);
      return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

/// A child process: argv[0] is the program; stdout and stderr go to `log` (or /dev/null).
pid_t spawn(const std::vector<std::string>& args, const std::string& log = "/dev/null") {
  const pid_t pid = fork();
  if (pid == 0) {
    const int out = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out >= 0) {
      dup2(out, 1);
      dup2(out, 2);
    }
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

void stop_child(pid_t pid) {
  if (pid <= 0) return;
  kill(pid, SIGTERM);
  for (int i = 0; i < 100; ++i) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
}

struct Latencies {
  std::vector<double> ms;
  int failures = 0;
  double pct(double p) const {
    if (ms.empty()) return 0;
    std::vector<double> v = ms;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<size_t>(p * double(v.size())))];
  }
};

/// The normal client: 20 requests a second for `seconds`, each on a fresh connection with 3 s
/// timeouts, until `stop` (or the time is up).
Latencies normal_client(int port, const std::string& path, const std::string& body,
                        double seconds) {
  Latencies out;
  const auto start = Clock::now();
  const int count = static_cast<int>(seconds * 20);
  for (int i = 0; i < count; ++i) {
    const auto t0 = Clock::now();
    httplib::Client c("127.0.0.1", port);
    c.set_connection_timeout(3, 0);
    c.set_read_timeout(3, 0);
    c.set_write_timeout(3, 0);
    auto res = c.Get(path.c_str());
    out.ms.push_back(ms_between(t0, Clock::now()));
    if (!res || res->status != 200 || res->body != body) ++out.failures;
    std::this_thread::sleep_until(start + std::chrono::milliseconds(50 * (i + 1)));
  }
  return out;
}

/// Trickling connections (see the header comment); returns how many the server cut.
int slowloris(int port, int count, double seconds, std::atomic<int>* held) {
  std::vector<int> fds;
  auto open_one = [port] {
    const int fd = osteon::test::connect_loopback(port);
    if (fd >= 0) {
      const char line[] = "GET /index.html HTTP/1.1\r\nHost: 127.0.0.1\r\n";
      send(fd, line, sizeof line - 1, MSG_NOSIGNAL);
    }
    return fd;
  };
  for (int i = 0; i < count; ++i) fds.push_back(open_one());
  int cuts = 0, line = 0;
  const auto start = Clock::now();
  auto next = start + std::chrono::seconds(2);
  while (ms_between(start, Clock::now()) < seconds * 1000) {
    std::vector<pollfd> polls;
    for (int fd : fds) polls.push_back({fd, POLLIN, 0});
    poll(polls.data(), polls.size(), 50);
    int open_now = 0;
    for (size_t k = 0; k < fds.size(); ++k) {
      if (fds[k] >= 0 && (polls[k].revents & (POLLIN | POLLHUP | POLLERR)) != 0) {
        char buffer[4096];
        if (recv(fds[k], buffer, sizeof buffer, MSG_DONTWAIT) <= 0) {
          close(fds[k]);
          ++cuts;
          fds[k] = open_one();
        }
      } else if (fds[k] < 0) {
        fds[k] = open_one();
      }
      open_now += fds[k] >= 0 ? 1 : 0;
    }
    held->store(open_now);
    if (Clock::now() >= next) {
      const std::string h = "X-Trickle-" + std::to_string(line++) + ": still here\r\n";
      for (int fd : fds) {
        if (fd >= 0) send(fd, h.data(), h.size(), MSG_NOSIGNAL);
      }
      next += std::chrono::seconds(2);
    }
  }
  for (int fd : fds) {
    if (fd >= 0) close(fd);
  }
  return cuts;
}

struct Site {
  std::string root;
  std::vector<std::string> paths;   // URL paths of every file
  std::vector<std::string> bodies;  // their bytes
  std::string largest;              // URL path of the largest file
  uint64_t bytes = 0;
};

Site read_site(const std::string& root) {
  Site site;
  site.root = root;
  uint64_t largest = 0;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = "/" + fs::relative(e.path(), root).generic_string();
    std::ifstream in(e.path(), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    if (bytes.size() >= largest) {
      largest = bytes.size();
      site.largest = rel;
    }
    site.bytes += bytes.size();
    site.paths.push_back(rel);
    site.bodies.push_back(std::move(bytes));
  }
  return site;
}

struct Load {
  uint64_t requests = 0, failures = 0, bytes = 0;
  double seconds = 0;
};

Load load(int port, const Site& site, int clients, double seconds) {
  std::atomic<uint64_t> requests{0}, failures{0}, bytes{0};
  const auto start = Clock::now();
  const auto until = start + std::chrono::duration<double>(seconds);
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i) {
    threads.emplace_back([&, i] {
      httplib::Client c("127.0.0.1", port);
      c.set_keep_alive(true);
      c.set_connection_timeout(3, 0);
      c.set_read_timeout(3, 0);
      for (size_t k = size_t(i) * 7; Clock::now() < until; ++k) {
        const size_t f = k % site.paths.size();
        auto res = c.Get(site.paths[f].c_str());
        ++requests;
        if (!res || res->status != 200 || res->body != site.bodies[f]) {
          ++failures;
        } else {
          bytes += res->body.size();
        }
      }
    });
  }
  for (std::thread& t : threads) t.join();
  return {requests.load(), failures.load(), bytes.load(), ms_between(start, Clock::now()) / 1000};
}

/// Clients that vanish mid-response, then hostile requests; returns the statuses seen, in order.
std::string vanish_and_hostile(int port, const Site& site, int clients) {
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i) {
    threads.emplace_back([&, i] {
      const int fd = osteon::test::connect_loopback(port);
      if (fd < 0) return;
      const std::string req = "GET " + site.largest + " HTTP/1.1\r\nHost: x\r\n\r\n";
      send(fd, req.data(), req.size(), MSG_NOSIGNAL);
      char buffer[16384];
      (void)recv(fd, buffer, sizeof buffer, MSG_WAITALL);
      if (i % 2 == 1) {
        linger hard{1, 0};
        setsockopt(fd, SOL_SOCKET, SO_LINGER, &hard, sizeof hard);
      }
      close(fd);
    });
  }
  for (std::thread& t : threads) t.join();
  const std::string end = " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  const std::vector<std::string> hostile = {
      "GET http://127.0.0.1/index.html" + end,
      "GET /../index.html" + end,
      "GET /c/%2e%2e/%2E%2E/etc/passwd" + end,
      "GET /c\\..\\index.html" + end,
      "GET /index.html%00.png" + end,
      std::string("GET /index.html\0.png", 20) + end,
      "GET /index.html\r\n\r\n",
      "GET /index.html HTTP/2.0\r\nHost: x\r\n\r\n",
      "GET /index.html HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(70000, 'a') + "\r\n\r\n",
      "GET /" + std::string(70000, 'a') + end,
      "POST /index.html HTTP/1.1\r\nHost: x\r\n"
      "Content-Length: 5\r\n\r\nhello",
      "GET /index%zz.html" + end};
  std::string statuses;
  for (const std::string& request : hostile) {
    const int fd = osteon::test::connect_loopback(port);
    if (fd < 0) continue;
    send(fd, request.data(), request.size(), MSG_NOSIGNAL);
    char buffer[256] = {};
    pollfd p{fd, POLLIN, 0};
    std::string status = "-";
    if (poll(&p, 1, 3000) > 0 && recv(fd, buffer, sizeof buffer - 1, 0) > 12) {
      status = std::string(buffer + 9, 3);
    }
    close(fd);
    statuses += (statuses.empty() ? "" : " ") + status;
  }
  return statuses;
}

struct ServerRun {
  std::string name;
  Latencies slow_normal;
  int slow_cuts = 0;
  int slow_held = 0;
  Load busy;
  Latencies busy_normal;
  long rss_start = -1, rss_end = -1, rss_peak = -1;
  std::string hostile;
  bool intact_after = false;
};

/// Runs the phases against a server already listening on `port` (process `pid`).
ServerRun measure(const std::string& name, pid_t pid, int port, const Site& site, int trickles,
                  double slow_seconds, int clients, double seconds, bool abuse) {
  ServerRun run;
  run.name = name;
  const size_t index =
      size_t(std::find(site.paths.begin(), site.paths.end(), "/index.html") - site.paths.begin());
  const std::string& index_body = index < site.bodies.size() ? site.bodies[index] : site.bodies[0];
  const std::string index_path = index < site.paths.size() ? "/index.html" : site.paths[0];
  normal_client(port, index_path, index_body, 0.5);  // warm
  run.rss_start = rss_kib(pid);
  std::atomic<bool> sampling{true};
  std::atomic<long> peak{run.rss_start};
  std::thread sampler([&] {
    while (sampling) {
      peak = std::max(peak.load(), rss_kib(pid));
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
  });

  std::fprintf(stderr, "serve_bench: %s: slowloris, %d trickles for %.0f s\n", name.c_str(),
               trickles, slow_seconds);
  std::atomic<int> held{0};
  int cuts = 0;
  std::thread attacker([&] { cuts = slowloris(port, trickles, slow_seconds, &held); });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  run.slow_normal = normal_client(port, index_path, index_body, slow_seconds - 1.0);
  run.slow_held = held.load();
  attacker.join();
  run.slow_cuts = cuts;

  std::fprintf(stderr, "serve_bench: %s: %d clients over %zu files for %.0f s\n", name.c_str(),
               clients, site.paths.size(), seconds);
  std::thread watcher(
      [&] { run.busy_normal = normal_client(port, index_path, index_body, seconds); });
  run.busy = load(port, site, clients, seconds);
  watcher.join();

  if (abuse) {
    std::fprintf(stderr, "serve_bench: %s: vanishing clients and hostile requests\n", name.c_str());
    run.hostile = vanish_and_hostile(port, site, clients);
    bool intact = true;
    for (size_t f = 0; f < site.paths.size(); ++f) {
      httplib::Client c("127.0.0.1", port);
      auto res = c.Get(site.paths[f].c_str());
      intact = intact && res && res->status == 200 && res->body == site.bodies[f];
    }
    run.intact_after = intact;
  }
  std::this_thread::sleep_for(std::chrono::seconds(6));  // idle connections time out
  run.rss_end = rss_kib(pid);
  sampling = false;
  sampler.join();
  run.rss_peak = std::max(peak.load(), run.rss_end);
  return run;
}

std::string mb(long kib) {
  return kib < 0 ? "-" : osteon_bench::fixed(double(kib) / 1024.0, 1);
}

std::string row(const ServerRun& r) {
  using osteon_bench::fixed;
  using osteon_bench::grouped;
  const double rps = r.busy.seconds > 0 ? double(r.busy.requests) / r.busy.seconds : 0;
  const double mbps = r.busy.seconds > 0 ? double(r.busy.bytes) / 1e6 / r.busy.seconds : 0;
  return "| " + r.name + " | " + std::to_string(r.slow_normal.ms.size()) + " / " +
         std::to_string(r.slow_normal.failures) + " | " + fixed(r.slow_normal.pct(0.5), 1) + " / " +
         fixed(r.slow_normal.pct(0.99), 1) + " / " + fixed(r.slow_normal.pct(1.0), 1) + " | " +
         std::to_string(r.slow_cuts) + " | " + grouped(uint64_t(rps)) + " | " + fixed(mbps, 1) +
         " | " + std::to_string(r.busy.failures) + " | " + fixed(r.busy_normal.pct(0.5), 1) +
         " / " + fixed(r.busy_normal.pct(0.99), 1) + " / " + fixed(r.busy_normal.pct(1.0), 1) +
         " (" + std::to_string(r.busy_normal.failures) + " failed) | " + mb(r.rss_start) + " / " +
         mb(r.rss_peak) + " / " + mb(r.rss_end) + " |\n";
}

/// Replaces the text between this bench's markers in `path` (appending heading and markers
/// when absent), leaving every other section as it is.
bool write_between_markers(const fs::path& path, const std::string& body) {
  const std::string begin =
      "<!-- bench/serve_bench: begin (written by the program; edits here "
      "are overwritten) -->";
  const std::string end = "<!-- bench/serve_bench: end -->";
  std::string text;
  {
    std::ifstream in(path);
    if (in) text.assign(std::istreambuf_iterator<char>(in), {});
  }
  const size_t b = text.find(begin);
  const size_t e = b == std::string::npos ? std::string::npos : text.find(end, b);
  const std::string block = begin + "\n" + body + end;
  if (b == std::string::npos || e == std::string::npos) {
    if (!text.empty() && text.back() != '\n') text += "\n";
    text += "\n## serve_bench: osteon serve under slow, numerous and hostile clients\n\n" + block +
            "\n";
  } else {
    text.replace(b, e + end.size() - b, block);
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  return bool(out);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"osteon serve under slowloris, load, vanishing and hostile clients, against nginx"};
  double seconds = 600, slow_seconds = 30;
  int trickles = 1000, clients = 200, threads = 4;
  std::string package, osteon = OSTEON_CLI_PATH, nginx = "/usr/sbin/nginx", write;
  std::string data = std::string(OSTEON_SHARED_DATA_DIR) + "/aHer-dev__3DAnatomy/models/bones";
  app.add_option("--seconds", seconds, "length of the load phase, per server (default 600)");
  app.add_option("--slowloris-seconds", slow_seconds, "length of the slowloris phase (default 30)");
  app.add_option("--slowloris", trickles, "trickling connections (default 1000)");
  app.add_option("--clients", clients, "clients looping over the package (default 200)");
  app.add_option("--threads", threads, "osteon serve --threads, nginx worker_processes (4)");
  app.add_option("--package", package, "a package folder to serve (default: pack BodyParts3D)");
  app.add_option("--osteon", osteon, "the osteon binary");
  app.add_option("--nginx", nginx, "the nginx binary ('' skips it)");
  app.add_option("--write", write, "replace this bench's section of FILE (docs/BENCHMARKS.md)");
  CLI11_PARSE(app, argc, argv);
  signal(SIGPIPE, SIG_IGN);
  rlimit files{};
  getrlimit(RLIMIT_NOFILE, &files);
  files.rlim_cur = files.rlim_max;
  setrlimit(RLIMIT_NOFILE, &files);

  const fs::path work =
      fs::temp_directory_path() / ("osteon-serve-bench-" + std::to_string(getpid()));
  fs::create_directories(work);
  std::string input = "generated phantom";
  if (package.empty()) {
    package = (work / "site").string();
    std::vector<std::string> pack = {osteon, "pack"};
    if (fs::is_directory(data)) {
      input = "BodyParts3D bones (" + fs::path(data).filename().string() + ", packed)";
      pack.push_back(data);
    } else {
      const std::string phantom = (work / "phantom").string();
      const pid_t p = spawn({osteon, "phantom", "-o", phantom});
      waitpid(p, nullptr, 0);
      pack.push_back(phantom);
    }
    pack.insert(pack.end(), {"-o", package});
    std::fprintf(stderr, "serve_bench: packing %s\n", input.c_str());
    const pid_t p = spawn(pack, (work / "pack.log").string());
    int status = 0;
    waitpid(p, &status, 0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      std::fprintf(stderr, "serve_bench: osteon pack failed (see %s)\n",
                   (work / "pack.log").c_str());
      return 1;
    }
  } else {
    input = package;
  }
  const Site site = read_site(package);
  if (site.paths.empty()) {
    std::fprintf(stderr, "serve_bench: %s holds no files\n", package.c_str());
    return 1;
  }
  slow_seconds = std::min(slow_seconds, std::max(5.0, seconds));

  std::vector<ServerRun> runs;
  {
    const int port = free_port();
    const pid_t pid = spawn({osteon, "serve", package, "--port", std::to_string(port), "--threads",
                             std::to_string(threads)});
    if (!wait_until_serving(port, 10)) {
      std::fprintf(stderr, "serve_bench: osteon serve did not start\n");
      stop_child(pid);
      return 1;
    }
    runs.push_back(
        measure("osteon serve (libmicrohttpd, " + std::to_string(threads) + " epoll threads)", pid,
                port, site, trickles, slow_seconds, clients, seconds, true));
    stop_child(pid);
  }
  if (!nginx.empty() && fs::exists(nginx)) {
    const fs::path prefix = work / "nginx";
    fs::create_directories(prefix / "tmp");
    const int port = free_port();
    std::ofstream conf(prefix / "nginx.conf");
    conf << "worker_processes " << threads << ";\ndaemon off;\npid "
         << (prefix / "nginx.pid").string() << ";\nerror_log " << (prefix / "error.log").string()
         << ";\nevents { worker_connections " << 4 * (trickles + clients + 64)
         << "; }\nhttp {\n  access_log /dev/null;\n"
         << "  types { text/html html; text/javascript js mjs; application/json json; "
            "application/wasm wasm; text/css css; }\n  default_type application/octet-stream;\n"
         << "  sendfile on;\n  tcp_nopush on;\n  keepalive_timeout 2s;\n  keepalive_requests 100;\n"
         << "  client_body_temp_path " << (prefix / "tmp").string() << ";\n  proxy_temp_path "
         << (prefix / "tmp").string() << ";\n  fastcgi_temp_path " << (prefix / "tmp").string()
         << ";\n  uwsgi_temp_path " << (prefix / "tmp").string() << ";\n  scgi_temp_path "
         << (prefix / "tmp").string() << ";\n  server {\n    listen 127.0.0.1:" << port
         << ";\n    root " << package << ";\n  }\n}\n";
    conf.close();
    const pid_t pid = spawn({nginx, "-p", prefix.string(), "-c", (prefix / "nginx.conf").string(),
                             "-e", (prefix / "error.log").string()});
    if (wait_until_serving(port, 10)) {
      ServerRun r = measure("nginx " + std::to_string(threads) + " workers", pid, port, site,
                            trickles, slow_seconds, clients, seconds, false);
      runs.push_back(r);
    } else {
      std::fprintf(stderr, "serve_bench: nginx did not start (see %s)\n",
                   (prefix / "error.log").c_str());
    }
    stop_child(pid);
  }

  std::string command = "build-bench/serve_bench";
  for (int i = 1; i < argc; ++i) command += std::string(" ") + argv[i];
  std::string body;
  body += "```sh\n" + command + "\n```\n\n";
  body += "Package: " + input + ", " + std::to_string(site.paths.size()) + " files, " +
          osteon_bench::grouped(site.bytes) + " bytes. Machine: " + osteon_bench::cpu_model() +
          ", " + std::to_string(std::thread::hardware_concurrency()) +
          " hardware threads (shared; clients and server on the same cores). Slowloris: " +
          std::to_string(trickles) +
          " connections from 127.0.0.1 each sending a header line every "
          "2 s for " +
          osteon_bench::fixed(slow_seconds, 0) +
          " s, replaced when cut, while the "
          "normal client (same address, a fresh connection per request, 3 s timeouts) asks 20 "
          "times a second. Load: " +
          std::to_string(clients) +
          " keep-alive clients looping over "
          "every file for " +
          osteon_bench::fixed(seconds, 0) +
          " s, each body checked, with the "
          "normal client asking alongside. Latencies in ms.\n\n";
  body +=
      "| server | slowloris: normal requests / failed | p50 / p99 / max | trickles cut | "
      "load: requests/s | MB/s | failed | normal client p50 / p99 / max | RSS MB start / "
      "peak / end (nginx: master and workers) |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const ServerRun& r : runs) body += row(r);
  if (!runs.empty() && !runs[0].hostile.empty()) {
    body += "\nThen " + std::to_string(clients) +
            " clients vanished mid-response (half with a "
            "reset) and the hostile requests (absolute URI, dot-dot, encoded dot-dot, backslash, "
            "encoded NUL, raw NUL, HTTP/0.9, HTTP/2.0, 70 kB header, 70 kB target, POST, bad "
            "escape) got " +
            runs[0].hostile + "; afterwards every file was " +
            (runs[0].intact_after ? "still served byte for byte" : "NOT served right") + ".\n";
  }
  std::printf("%s", body.c_str());
  if (!write.empty() && !write_between_markers(write, body)) {
    std::fprintf(stderr, "serve_bench: cannot write %s\n", write.c_str());
    return 1;
  }
  std::error_code ec;
  fs::remove_all(work, ec);
  return 0;
}
