// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "osteon/status.hpp"

// Based on: RFC 9110 (conditional requests, Range, content negotiation) and RFC 9111
// (Cache-Control, `immutable` from RFC 8246). HTTP parsing and the socket loop are cpp-httplib's
// (Debian 12, 0.11.4); this file decides what a request for a path inside the package folder gets.

namespace osteon {

/// How `osteon serve` serves a package folder.
struct ServeOptions {
  std::string root;                ///< the folder served (must exist and be a directory)
  std::string host = "127.0.0.1";  ///< loopback by default: nothing leaves the machine unasked
  int port = 8080;                 ///< 0 picks a free port (FileServer::port() then says which)
  int threads = 64;                ///< worker threads: each holds one connection at a time
  int keep_alive_seconds = 2;  ///< an idle keep-alive connection gives its worker back after this
  int keep_alive_requests = 100;  ///< requests per connection before the server closes it
  /// Called once per request, from worker threads, with "GET /path 200 1234 B 0.3 ms"; may be
  /// empty.
  std::function<void(const std::string&)> log;
};

/// The MIME type served for a file name, by extension (".wasm" -> "application/wasm", ".ostm" ->
/// "application/octet-stream", unknown -> "application/octet-stream").
std::string mime_type(const std::string& name);

/// True when the file name (its last path segment) carries a content hash: a run of at least 16 hex
/// digits, as `osteon pack` names component files (c/3f2a9b....ostm). Such files are served with
/// `Cache-Control: public, max-age=31536000, immutable`; every other file with `no-cache`.
bool is_content_hashed(const std::string& name);

/// A static file server for a package folder, running on background threads.
///
/// GET and HEAD only. Serves files under `root` with MIME types, strong ETags (size and mtime) and
/// If-None-Match -> 304, single byte ranges (206, 416 when unsatisfiable; a multi-range request
/// gets the whole file), precompressed `X.gz` beside X when Accept-Encoding allows gzip (never for
/// a Range request), and cache headers per is_content_hashed(). A directory serves its index.html.
/// Refuses with 403 every path that leaves root: `..` segments (also percent-encoded), backslashes,
/// NUL, and symlinks whose target resolves outside root (paths are canonicalised and
/// prefix-checked). Known approximation: files are read whole into memory per request (package
/// files are small).
class FileServer {
 public:
  FileServer();
  ~FileServer();  ///< stops the server if it is running
  FileServer(const FileServer&) = delete;
  FileServer& operator=(const FileServer&) = delete;

  /// Binds host:port and starts serving on a background thread.
  /// Errors: kInvalidArgument when root is missing or not a directory, or the port is out of
  /// range; kIoError when the address cannot be bound (the message names host and port).
  Status start(const ServeOptions& options);
  /// The bound port (the one picked when options.port was 0); 0 before start().
  int port() const;
  /// True between a successful start() and stop().
  bool running() const;
  /// Stops accepting, finishes the requests in flight and joins the threads. Idempotent.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace osteon
