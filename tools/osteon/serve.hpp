// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "osteon/status.hpp"

// Based on: RFC 9110 (conditional requests, Range, content negotiation, 405/503) and RFC 9111
// (Cache-Control, `immutable` from RFC 8246). HTTP parsing and the event loop are GNU
// libmicrohttpd's (Debian 12, 0.9.75: a few epoll threads, connection and per-address limits);
// this file decides what a request for a path inside the package folder gets.

namespace osteon {

/// How `osteon serve` serves a package folder.
struct ServeOptions {
  std::string root;                ///< the folder served (must exist and be a directory)
  std::string host = "127.0.0.1";  ///< loopback by default: nothing leaves the machine unasked
  int port = 8080;                 ///< 0 picks a free port (FileServer::port() then says which)
  /// Event-loop threads, each with its own epoll set and share of the connections. A thread is
  /// not held by a connection: a slow or idle client costs a socket and a few KiB, not a worker.
  int threads = 4;
  /// Connections served at once. Up to max_connections / 8 more (at least 8) are accepted only to
  /// be answered `503 Service Unavailable` with `Retry-After: 1` and closed; beyond that the
  /// kernel's listen queue holds them, or the event loop closes them at once (libmicrohttpd
  /// shares that hard limit out among the threads).
  int max_connections = 2048;
  /// Connections from one client address at once; more are closed as soon as they are accepted.
  /// -1 (the default): no limit on a loopback address, where every client has the same address
  /// and a per-address limit would be a global one, and 64 on any other; 0: no limit.
  int max_per_client = -1;
  /// A request (request line, headers and any body) must be complete within this many seconds of
  /// the connection opening, or of its request line on a kept-alive connection: a client that
  /// trickles a header line every second is cut off here, not kept alive by its own trickle.
  int header_timeout_seconds = 5;
  /// An idle keep-alive connection is closed when no new request has begun within this many
  /// seconds of the previous response; the request, once begun, has header_timeout_seconds.
  int keep_alive_seconds = 2;
  int keep_alive_requests = 100;  ///< requests per connection before the server closes it
  /// A connection on which no byte moves, either way, for this many seconds is closed (a client
  /// that stops reading its response, say).
  int idle_timeout_seconds = 5;
  /// Called once per request, from the event-loop threads, with "GET /path 200 1234 B 0.3 ms"
  /// once the response has been sent (", aborted" appended when the client went away first;
  /// requests the HTTP parser refuses itself show the method as "-"); may be empty.
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
/// GET and HEAD only: any other method gets 405 with `Allow: GET, HEAD`. Serves files under
/// `root` with MIME types, strong ETags (size and mtime) and If-None-Match -> 304, single byte
/// ranges (206, 416 when unsatisfiable; a multi-range or unparsable Range gets the whole file),
/// precompressed `X.gz` beside X when Accept-Encoding allows gzip (never for a Range request), and
/// cache headers per is_content_hashed(). A directory serves its index.html. Refuses with 403
/// every path that leaves root: `..` segments (also percent-encoded), backslashes, NUL, absolute
/// URIs, and symlinks whose target resolves outside root (paths are canonicalised and
/// prefix-checked); a malformed percent-escape is 400, as are requests the HTTP parser rejects
/// (HTTP/0.9, bad request lines; over-long targets 414, over-large headers 431, unsupported
/// versions 505). File bodies are sent from the open file (sendfile), never read into memory.
/// The limits and deadlines of ServeOptions bound what slow, idle or numerous clients can hold.
class FileServer {
 public:
  FileServer();
  ~FileServer();  ///< stops the server if it is running
  FileServer(const FileServer&) = delete;
  FileServer& operator=(const FileServer&) = delete;

  /// Binds host:port and starts serving on background threads. Raises the process's soft limit
  /// on open files, when it is lower, to what the connection limits need (up to the hard limit).
  /// Errors: kInvalidArgument when root is missing or not a directory, or the port or a limit is
  /// out of range; kIoError when the address cannot be bound (the message names host and port)
  /// or the event loop cannot start.
  Status start(const ServeOptions& options);
  /// The bound port (the one picked when options.port was 0); 0 before start().
  int port() const;
  /// True between a successful start() and stop().
  bool running() const;
  /// Stops accepting, closes every connection (a response in flight is cut) and joins the
  /// threads. Idempotent.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace osteon
