// SPDX-License-Identifier: Apache-2.0
#include "serve.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>

#include "fixtures.hpp"
#include "serve_client.hpp"

// The package server: MIME types, cache headers, ETag/304, Range, precompressed gzip, path
// traversal refused, other methods 405, malformed requests refused, files streamed rather than
// read whole, 200 concurrent requests, and the CLI's errors. Every server binds port 0 on loopback
// inside a scratch folder. Slow, numerous, vanishing and hostile clients: serve_abuse_test.cpp.

namespace osteon {
namespace {

namespace fs = std::filesystem;

const std::string kHash = "3f2a9b01c4d5e6f70123456789abcdef";

/// A package-like folder: index.html, manifest.json (+ .gz), a script, a stylesheet, the WASM
/// decoder, an image and a content-hashed component c/<hash>.ostm of 1000 bytes. Beside it (outside
/// the folder) a secret file.
struct Package {
  std::string parent;
  std::string root;
  std::string component;  // bytes of c/<hash>.ostm
};

Package make_package() {
  Package p;
  p.parent = test::scratch_dir();
  p.root = p.parent + "/site";
  fs::create_directories(p.root + "/c");
  fs::create_directories(p.root + "/sub");
  fs::create_directories(p.root + "/empty");
  test::write_bytes(p.root + "/index.html", "<!doctype html><title>osteon</title>");
  test::write_bytes(p.root + "/sub/index.html", "sub index");
  test::write_bytes(p.root + "/manifest.json", "{\"format\": 1}");
  test::write_bytes(p.root + "/manifest.json.gz", std::string("\x1f\x8b\x08\x00gz-bytes", 12));
  test::write_bytes(p.root + "/viewer.js", "export const x = 1;");
  test::write_bytes(p.root + "/worker.mjs", "export {};");
  test::write_bytes(p.root + "/style.css", "body{}");
  test::write_bytes(p.root + "/osteon_decoder.wasm", std::string("\0asm\1\0\0\0", 8));
  test::write_bytes(p.root + "/logo.png", "\x89PNG");
  for (int i = 0; i < 1000; ++i) p.component.push_back(static_cast<char>((i * 7 + 3) & 0xff));
  test::write_bytes(p.root + "/c/" + kHash + ".ostm", p.component);
  test::write_bytes(p.parent + "/secret", "do not serve");
  fs::create_symlink(p.parent + "/secret", p.root + "/leak");
  fs::create_symlink(p.parent, p.root + "/up");
  return p;
}

/// A server on a free loopback port for the duration of a test.
struct Running {
  Package package = make_package();
  // Declared before the server: the server's threads log into them until it stops.
  std::mutex log_mutex;
  std::vector<std::string> log;
  FileServer server;

  explicit Running(const std::function<void(ServeOptions&)>& tune = {}) {
    ServeOptions options;
    options.root = package.root;
    options.port = 0;
    if (tune) tune(options);
    options.log = [this](const std::string& line) {
      std::lock_guard<std::mutex> lock(log_mutex);
      log.push_back(line);
    };
    const Status status = server.start(options);
    EXPECT_TRUE(status.ok()) << status.message();
  }
  ~Running() { server.stop(); }
  httplib::Client client() const {
    httplib::Client c("127.0.0.1", server.port());
    c.set_decompress(false);  // precompressed bodies are compared byte for byte
    return c;
  }
};

/// Sends one request line exactly as given (no client-side normalisation or escaping) and returns
/// the response status, or -1.
int raw_status(int port, const std::string& target) {
  return test::status_of(test::raw_exchange(
      port, "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n"));
}

/// Resident memory of this process, in KiB (VmRSS).
long rss_kib() {
  FILE* f = std::fopen("/proc/self/status", "r");
  if (f == nullptr) return -1;
  char line[256];
  long kib = -1;
  while (std::fgets(line, sizeof line, f) != nullptr) {
    if (std::strncmp(line, "VmRSS:", 6) == 0) kib = std::atol(line + 6);
  }
  std::fclose(f);
  return kib;
}

TEST(Serve, MimeTypesAndHashedNames) {
  EXPECT_EQ(mime_type("osteon_decoder.wasm"), "application/wasm");
  EXPECT_EQ(mime_type("manifest.json"), "application/json");
  EXPECT_EQ(mime_type("a/b/viewer.JS"), "text/javascript; charset=utf-8");
  EXPECT_EQ(mime_type("c/" + kHash + ".ostm"), "application/octet-stream");
  EXPECT_EQ(mime_type("noextension"), "application/octet-stream");
  EXPECT_TRUE(is_content_hashed("c/" + kHash + ".ostm"));
  EXPECT_TRUE(is_content_hashed("viewer-0123456789abcdef.js"));
  EXPECT_FALSE(is_content_hashed("viewer-0123456789abcde.js"));  // 15 hex digits
  EXPECT_FALSE(is_content_hashed("manifest.json"));
  EXPECT_FALSE(is_content_hashed("0123456789abcdef/index.html"));  // only the file name counts
}

TEST(Serve, ContentTypesAndCacheHeaders) {
  Running r;
  auto c = r.client();
  const std::pair<std::string, std::string> cases[] = {
      {"/", "text/html; charset=utf-8"},
      {"/index.html", "text/html; charset=utf-8"},
      {"/viewer.js", "text/javascript; charset=utf-8"},
      {"/worker.mjs", "text/javascript; charset=utf-8"},
      {"/style.css", "text/css; charset=utf-8"},
      {"/osteon_decoder.wasm", "application/wasm"},
      {"/logo.png", "image/png"},
      {"/manifest.json", "application/json"},
      {"/c/" + kHash + ".ostm", "application/octet-stream"},
  };
  for (const auto& [path, type] : cases) {
    auto res = c.Get(path.c_str());
    ASSERT_TRUE(res) << path;
    EXPECT_EQ(res->status, 200) << path;
    EXPECT_EQ(res->get_header_value("Content-Type"), type) << path;
    if (path.rfind("/c/", 0) != 0) {
      EXPECT_EQ(res->get_header_value("Cache-Control"), "no-cache") << path;
    }
  }
  auto hashed = c.Get(("/c/" + kHash + ".ostm").c_str());
  ASSERT_TRUE(hashed);
  EXPECT_EQ(hashed->body, r.package.component);
}

TEST(Serve, ImmutableOnlyForHashedFiles) {
  Running r;
  auto c = r.client();
  auto hashed = c.Get(("/c/" + kHash + ".ostm").c_str());
  ASSERT_TRUE(hashed);
  EXPECT_EQ(hashed->get_header_value("Cache-Control"), "public, max-age=31536000, immutable");
  EXPECT_EQ(c.Get("/manifest.json")->get_header_value("Cache-Control"), "no-cache");
  EXPECT_EQ(c.Get("/index.html")->get_header_value("Cache-Control"), "no-cache");
}

TEST(Serve, DirectoriesServeTheirIndexElse404) {
  Running r;
  auto c = r.client();
  auto sub = c.Get("/sub/");
  ASSERT_TRUE(sub);
  EXPECT_EQ(sub->status, 200);
  EXPECT_EQ(sub->body, "sub index");
  EXPECT_EQ(c.Get("/empty/")->status, 404);
  EXPECT_EQ(c.Get("/missing.json")->status, 404);
  EXPECT_EQ(c.Get("/c/missing.ostm")->status, 404);
}

TEST(Serve, ETagAndIfNoneMatch) {
  Running r;
  auto c = r.client();
  const std::string path = "/c/" + kHash + ".ostm";
  auto first = c.Get(path.c_str());
  ASSERT_TRUE(first);
  const std::string etag = first->get_header_value("ETag");
  ASSERT_GE(etag.size(), 3u);
  EXPECT_EQ(etag.front(), '"');  // strong
  auto again = c.Get(path.c_str(), {{"If-None-Match", etag}});
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 304);
  EXPECT_TRUE(again->body.empty());
  EXPECT_EQ(again->get_header_value("ETag"), etag);
  auto other = c.Get(path.c_str(), {{"If-None-Match", "\"stale\", W/\"older\""}});
  ASSERT_TRUE(other);
  EXPECT_EQ(other->status, 200);
  EXPECT_EQ(c.Get(path.c_str(), {{"If-None-Match", "\"x\", " + etag}})->status, 304);
}

TEST(Serve, SingleRanges) {
  Running r;
  auto c = r.client();
  const std::string path = "/c/" + kHash + ".ostm";
  auto mid = c.Get(path.c_str(), {{"Range", "bytes=10-19"}});
  ASSERT_TRUE(mid);
  EXPECT_EQ(mid->status, 206);
  EXPECT_EQ(mid->get_header_value("Content-Range"), "bytes 10-19/1000");
  EXPECT_EQ(mid->body, r.package.component.substr(10, 10));
  auto tail = c.Get(path.c_str(), {{"Range", "bytes=-5"}});
  ASSERT_TRUE(tail);
  EXPECT_EQ(tail->status, 206);
  EXPECT_EQ(tail->get_header_value("Content-Range"), "bytes 995-999/1000");
  EXPECT_EQ(tail->body, r.package.component.substr(995));
  auto open = c.Get(path.c_str(), {{"Range", "bytes=990-5000"}});
  ASSERT_TRUE(open);
  EXPECT_EQ(open->status, 206);
  EXPECT_EQ(open->body, r.package.component.substr(990));
  auto beyond = c.Get(path.c_str(), {{"Range", "bytes=1000-1010"}});
  ASSERT_TRUE(beyond);
  EXPECT_EQ(beyond->status, 416);
  EXPECT_EQ(beyond->get_header_value("Content-Range"), "bytes */1000");
}

TEST(Serve, PrecompressedGzip) {
  Running r;
  auto c = r.client();
  auto plain = c.Get("/manifest.json");
  ASSERT_TRUE(plain);
  EXPECT_EQ(plain->body, "{\"format\": 1}");
  EXPECT_FALSE(plain->has_header("Content-Encoding"));
  EXPECT_EQ(plain->get_header_value("Vary"), "Accept-Encoding");
  auto gz = c.Get("/manifest.json", {{"Accept-Encoding", "br, gzip;q=0.8"}});
  ASSERT_TRUE(gz);
  EXPECT_EQ(gz->status, 200);
  EXPECT_EQ(gz->get_header_value("Content-Encoding"), "gzip");
  EXPECT_EQ(gz->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(gz->get_header_value("Vary"), "Accept-Encoding");
  EXPECT_EQ(gz->body, std::string("\x1f\x8b\x08\x00gz-bytes", 12));
  EXPECT_NE(gz->get_header_value("ETag"), plain->get_header_value("ETag"));
  auto refused = c.Get("/manifest.json", {{"Accept-Encoding", "gzip;q=0"}});
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->body, "{\"format\": 1}");
  auto ranged = c.Get("/manifest.json", {{"Accept-Encoding", "gzip"}, {"Range", "bytes=0-3"}});
  ASSERT_TRUE(ranged);
  EXPECT_EQ(ranged->status, 206);
  EXPECT_FALSE(ranged->has_header("Content-Encoding"));
  EXPECT_EQ(ranged->body, "{\"fo");
  // No sibling .gz: served as is, without on-the-fly compression.
  auto js = c.Get("/viewer.js", {{"Accept-Encoding", "gzip"}});
  ASSERT_TRUE(js);
  EXPECT_FALSE(js->has_header("Content-Encoding"));
  EXPECT_EQ(js->body, "export const x = 1;");
}

TEST(Serve, PathsOutsideTheFolderAreRefused) {
  Running r;
  const int port = r.server.port();
  ASSERT_EQ(raw_status(port, "/index.html"), 200);
  for (const std::string target :
       {"/../etc/passwd", "/../secret", "/%2e%2e/%2e%2e/etc/passwd", "/%2E%2E/secret",
        "/c/..%2f..%2fsecret", "/c/..%2F..%2F..%2Fetc%2Fpasswd", "/c/%2e%2e/%2e%2e/secret",
        "/..\\secret", "/c/..%5c..%5csecret", "/index.html%00.png", "/leak", "/up/secret",
        "//etc/passwd", "/etc/passwd"}) {
    const int status = raw_status(port, target);
    EXPECT_TRUE(status == 403 || status == 404 || status == 400) << target << " gave " << status;
  }
  // The dot-dot forms are refused outright, not merely not found.
  EXPECT_EQ(raw_status(port, "/../secret"), 403);
  EXPECT_EQ(raw_status(port, "/%2e%2e/%2e%2e/etc/passwd"), 403);
  EXPECT_EQ(raw_status(port, "/c/..%2f..%2fsecret"), 403);
  EXPECT_EQ(raw_status(port, "/leak"), 403);
  auto c = r.client();
  EXPECT_EQ(c.Get("/leak")->status, 403);
}

TEST(Serve, TwoHundredConcurrentRequests) {
  Running r;
  const int port = r.server.port();
  const std::string path = "/c/" + kHash + ".ostm";
  std::vector<std::future<bool>> answers;
  for (int i = 0; i < 200; ++i) {
    answers.push_back(std::async(std::launch::async, [&] {
      httplib::Client c("127.0.0.1", port);
      c.set_connection_timeout(5, 0);
      auto res = c.Get(path.c_str());
      return res && res->status == 200 && res->body == r.package.component;
    }));
  }
  int ok = 0;
  for (auto& a : answers) ok += a.get() ? 1 : 0;
  EXPECT_EQ(ok, 200);
  EXPECT_EQ(r.client().Get("/index.html")->status, 200);  // still up
}

TEST(Serve, HeadAndOtherMethods) {
  Running r;
  const int port = r.server.port();
  const std::string path = "/c/" + kHash + ".ostm";
  const std::string head = test::raw_exchange(
      port, "HEAD " + path + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(test::status_of(head), 200);
  EXPECT_EQ(test::header_of(head, "Content-Length"), "1000");
  EXPECT_EQ(test::header_of(head, "Content-Type"), "application/octet-stream");
  EXPECT_TRUE(test::body_of(head).empty());
  for (const std::string method : {"POST", "PUT", "DELETE", "PATCH", "OPTIONS", "TRACE"}) {
    const std::string response = test::raw_exchange(
        port, method + " /index.html HTTP/1.1\r\nHost: x\r\nContent-Length: 0\r\n\r\n");
    EXPECT_EQ(test::status_of(response), 405) << method;
    EXPECT_EQ(test::header_of(response, "Allow"), "GET, HEAD") << method;
  }
  auto c = r.client();
  auto posted = c.Post("/index.html", "x=1", "application/x-www-form-urlencoded");
  ASSERT_TRUE(posted);
  EXPECT_EQ(posted->status, 405);
  EXPECT_EQ(c.Get("/index.html")->status, 200);
}

TEST(Serve, LargeFilesAreStreamedNotReadWhole) {
  Running r;
  // 256 MiB, sparse: no disk, and the old read-whole server would have grown by that much.
  const std::string big = r.package.root + "/big.bin";
  test::write_bytes(big, "");
  fs::resize_file(big, 256u << 20);
  const long before = rss_kib();
  std::vector<std::thread> readers;
  std::atomic<uint64_t> received{0};
  for (int i = 0; i < 4; ++i) {
    readers.emplace_back([&] {
      const int fd = test::connect_loopback(r.server.port());
      if (fd < 0) return;
      test::send_all(fd, "GET /big.bin HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
      char buffer[1 << 16];
      ssize_t n;
      while ((n = recv(fd, buffer, sizeof buffer, 0)) > 0) received += uint64_t(n);
      close(fd);
    });
  }
  for (auto& t : readers) t.join();
  EXPECT_GE(received.load(), 4ull * (256u << 20));
  const long after = rss_kib();
  EXPECT_LT(after - before, 64 * 1024) << before << " KiB -> " << after << " KiB";
  // A range deep inside is sent from that offset.
  auto c = r.client();
  auto tail = c.Get("/big.bin", {{"Range", "bytes=268435000-268435455"}});
  ASSERT_TRUE(tail);
  EXPECT_EQ(tail->status, 206);
  EXPECT_EQ(tail->body, std::string(456, '\0'));
}

TEST(Serve, LogsOneLinePerRequest) {
  Running r;
  auto c = r.client();
  ASSERT_EQ(c.Get("/manifest.json")->status, 200);
  ASSERT_EQ(c.Get("/nope")->status, 404);
  r.server.stop();
  std::lock_guard<std::mutex> lock(r.log_mutex);
  ASSERT_EQ(r.log.size(), 2u);
  // Each line is written after its response, possibly by different workers: order is not fixed.
  std::sort(r.log.begin(), r.log.end());
  EXPECT_EQ(r.log[0].rfind("GET /manifest.json 200 13 B ", 0), 0u) << r.log[0];
  EXPECT_NE(r.log[0].find(" ms"), std::string::npos);
  EXPECT_EQ(r.log[1].rfind("GET /nope 404 ", 0), 0u) << r.log[1];
}

TEST(Serve, StartErrors) {
  const std::string dir = test::scratch_dir();
  FileServer server;
  ServeOptions options;
  options.port = 0;
  options.root = dir + "/absent";
  Status missing = server.start(options);
  EXPECT_EQ(missing.code(), ErrorCode::kInvalidArgument);
  EXPECT_NE(missing.message().find("no such folder"), std::string::npos);
  test::write_bytes(dir + "/file", "x");
  options.root = dir + "/file";
  EXPECT_EQ(server.start(options).code(), ErrorCode::kInvalidArgument);

  options.root = dir;
  ASSERT_TRUE(server.start(options).ok());
  FileServer second;
  options.port = server.port();
  Status in_use = second.start(options);
  EXPECT_EQ(in_use.code(), ErrorCode::kIoError);
  EXPECT_NE(in_use.message().find(std::to_string(server.port())), std::string::npos);
  server.stop();
  server.stop();  // idempotent
  EXPECT_FALSE(server.running());
}

TEST(Serve, CliErrors) {
  const std::string dir = test::scratch_dir();
  test::CliRun missing = test::run_cli("serve " + dir + "/absent --port 0");
  EXPECT_EQ(missing.status, 2);
  EXPECT_NE(missing.err.find("osteon: error: "), std::string::npos) << missing.err;
  EXPECT_NE(missing.err.find("no such folder"), std::string::npos) << missing.err;

  FileServer holder;
  ServeOptions options;
  options.root = dir;
  options.port = 0;
  ASSERT_TRUE(holder.start(options).ok());
  test::CliRun busy = test::run_cli("serve " + dir + " --port " + std::to_string(holder.port()));
  EXPECT_EQ(busy.status, 2);
  EXPECT_NE(busy.err.find("port " + std::to_string(holder.port())), std::string::npos) << busy.err;
}

}  // namespace
}  // namespace osteon
