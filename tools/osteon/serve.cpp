// SPDX-License-Identifier: Apache-2.0
#include "serve.hpp"

#include <sys/socket.h>
#include <sys/stat.h>

#include <atomic>
#include <cctype>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

#include <httplib.h>

// Based on: RFC 9110 sections 8.8.3 (ETag), 13.1.2 (If-None-Match), 14 (Range, Content-Range, 416)
// and 12.5.3 (Accept-Encoding); RFC 9111 section 5.2 and RFC 8246 (Cache-Control: immutable).
// cpp-httplib parses requests and runs the connection threads; everything a response says is
// decided here.

namespace osteon {

namespace fs = std::filesystem;

namespace {

constexpr const char* kImmutable = "public, max-age=31536000, immutable";
constexpr const char* kNoCache = "no-cache";

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string last_segment(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

/// True when `path` (canonical) is `root` or lies under it.
bool inside(const std::string& root, const std::string& path) {
  if (path == root) return true;
  const std::string prefix = root.back() == '/' ? root : root + "/";
  return path.compare(0, prefix.size(), prefix) == 0;
}

/// The canonical form of `path` when it exists and stays inside `root`; "" otherwise, with
/// `*escaped` set when it exists but resolves outside.
std::string canonical_inside(const std::string& root, const fs::path& path, bool* escaped) {
  std::error_code ec;
  const fs::path canon = fs::canonical(path, ec);
  if (ec) return {};
  std::string s = canon.string();
  if (!inside(root, s)) {
    *escaped = true;
    return {};
  }
  return s;
}

bool regular_file(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

/// Whether Accept-Encoding allows gzip: a `gzip`, `x-gzip` or `*` coding whose q is not 0.
bool accepts_gzip(const std::string& header) {
  size_t start = 0;
  while (start <= header.size()) {
    size_t end = header.find(',', start);
    if (end == std::string::npos) end = header.size();
    std::string item = lower(header.substr(start, end - start));
    start = end + 1;
    const size_t semi = item.find(';');
    std::string coding = item.substr(0, semi);
    coding.erase(0, coding.find_first_not_of(" \t"));
    coding.erase(coding.find_last_not_of(" \t") + 1);
    if (coding != "gzip" && coding != "x-gzip" && coding != "*") continue;
    bool zero = false;
    if (semi != std::string::npos) {
      const size_t q = item.find("q=", semi);
      if (q != std::string::npos) zero = std::strtod(item.c_str() + q + 2, nullptr) <= 0.0;
    }
    if (!zero) return true;
  }
  return false;
}

/// True when `etag` is listed in an If-None-Match value (weak comparison, or `*`).
bool etag_matches(const std::string& header, const std::string& etag) {
  size_t start = 0;
  while (start <= header.size()) {
    size_t end = header.find(',', start);
    if (end == std::string::npos) end = header.size();
    std::string item = header.substr(start, end - start);
    start = end + 1;
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (item == "*") return true;
    if (item.rfind("W/", 0) == 0) item.erase(0, 2);
    if (item == etag) return true;
  }
  return false;
}

enum class RangeKind { kNone, kSingle, kUnsatisfiable };

bool all_digits(const std::string& s) {
  if (s.empty() || s.size() > 18) return false;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
  }
  return true;
}

/// A `Range: bytes=a-b | a- | -n` header against a file of `size` bytes. Several ranges or an
/// unparsable value give kNone (the whole file is served, which RFC 9110 allows).
RangeKind parse_range(const std::string& header, uint64_t size, uint64_t* first, uint64_t* last) {
  const std::string v = lower(header);
  if (v.rfind("bytes=", 0) != 0) return RangeKind::kNone;
  std::string spec = v.substr(6);
  spec.erase(0, spec.find_first_not_of(" \t"));
  spec.erase(spec.find_last_not_of(" \t") + 1);
  if (spec.find(',') != std::string::npos) return RangeKind::kNone;
  const size_t dash = spec.find('-');
  if (dash == std::string::npos) return RangeKind::kNone;
  const std::string a = spec.substr(0, dash), b = spec.substr(dash + 1);
  if (a.empty()) {  // suffix: the last n bytes
    if (!all_digits(b)) return RangeKind::kNone;
    const uint64_t n = std::stoull(b);
    if (n == 0 || size == 0) return RangeKind::kUnsatisfiable;
    *first = size > n ? size - n : 0;
    *last = size - 1;
    return RangeKind::kSingle;
  }
  if (!all_digits(a) || (!b.empty() && !all_digits(b))) return RangeKind::kNone;
  const uint64_t from = std::stoull(a);
  const uint64_t to = b.empty() ? UINT64_MAX : std::stoull(b);
  if (to < from) return RangeKind::kNone;
  if (from >= size) return RangeKind::kUnsatisfiable;
  *first = from;
  *last = std::min<uint64_t>(to, size - 1);
  return RangeKind::kSingle;
}

bool read_slice(const std::string& path, uint64_t offset, uint64_t length, std::string* out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  in.seekg(static_cast<std::streamoff>(offset));
  out->resize(length);
  in.read(out->data(), static_cast<std::streamsize>(length));
  return static_cast<uint64_t>(in.gcount()) == length;
}

/// Request line for the log: control characters shown as '?'.
std::string printable(const std::string& s) {
  std::string out = s.substr(0, 512);
  for (char& c : out) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  }
  return out;
}

thread_local std::chrono::steady_clock::time_point t_request_start;
thread_local bool t_request_started = false;

}  // namespace

std::string mime_type(const std::string& name) {
  static const std::pair<const char*, const char*> kTypes[] = {
      {".html", "text/html; charset=utf-8"},
      {".htm", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".map", "application/json"},
      {".wasm", "application/wasm"},
      {".ostm", "application/octet-stream"},
      {".bin", "application/octet-stream"},
      {".txt", "text/plain; charset=utf-8"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".jpeg", "image/jpeg"},
      {".gif", "image/gif"},
      {".webp", "image/webp"},
      {".ico", "image/x-icon"},
      {".glb", "model/gltf-binary"},
      {".gltf", "model/gltf+json"},
  };
  const std::string base = lower(last_segment(name));
  const size_t dot = base.find_last_of('.');
  if (dot == std::string::npos) return "application/octet-stream";
  const std::string ext = base.substr(dot);
  for (const auto& [e, type] : kTypes) {
    if (ext == e) return type;
  }
  return "application/octet-stream";
}

bool is_content_hashed(const std::string& name) {
  const std::string base = last_segment(name);
  int run = 0;
  for (char c : base) {
    run = std::isxdigit(static_cast<unsigned char>(c)) ? run + 1 : 0;
    if (run >= 16) return true;
  }
  return false;
}

struct FileServer::Impl {
  ServeOptions options;
  std::string root;  // canonical
  std::unique_ptr<httplib::Server> server;
  std::thread thread;
  std::atomic<bool> listening_done{false};
  int port = 0;

  void handle(const httplib::Request& req, httplib::Response& res) const;
  void log(const httplib::Request& req, const httplib::Response& res) const;
};

void FileServer::Impl::handle(const httplib::Request& req, httplib::Response& res) const {
  // httplib slices res.body by req.ranges and gzips text bodies for clients that accept gzip, both
  // after this handler returns. Ranges and precompressed files are handled here (a strong ETag
  // must name exactly the bytes sent), so both are switched off for this request. The Request is
  // httplib's own non-const object, handed to handlers as const.
  auto& mutable_req = const_cast<httplib::Request&>(req);
  mutable_req.ranges.clear();
  const std::string accept_encoding = req.get_header_value("Accept-Encoding");
  mutable_req.headers.erase("Accept-Encoding");

  const std::string& url = req.path;  // percent-decoded by httplib
  auto refuse = [&res](int status) {
    res.status = status;
    res.set_content(status == 403 ? "403 forbidden\n" : "404 not found\n",
                    "text/plain; charset=utf-8");
  };
  if (url.empty() || url[0] != '/' || req.target.find('\\') != std::string::npos) {
    return refuse(403);
  }
  fs::path rel;
  size_t start = 1;
  while (start <= url.size()) {
    size_t end = url.find('/', start);
    if (end == std::string::npos) end = url.size();
    const std::string seg = url.substr(start, end - start);
    start = end + 1;
    if (seg.empty()) continue;
    if (seg == "." || seg == ".." || seg.find('\\') != std::string::npos ||
        seg.find('\0') != std::string::npos || seg.find(':') != std::string::npos) {
      return refuse(403);
    }
    rel /= seg;
  }

  bool escaped = false;
  std::string file = canonical_inside(root, fs::path(root) / rel, &escaped);
  if (file.empty()) return refuse(escaped ? 403 : 404);
  std::error_code ec;
  if (fs::is_directory(file, ec)) {
    file = canonical_inside(root, fs::path(file) / "index.html", &escaped);
    if (file.empty()) return refuse(escaped ? 403 : 404);
  }
  if (!regular_file(file)) return refuse(404);
  const std::string name = fs::path(file).filename().string();

  // The precompressed sibling X.gz, when there is one inside root.
  std::string gz;
  if (name.size() < 3 || name.compare(name.size() - 3, 3, ".gz") != 0) {
    bool gz_escaped = false;
    gz = canonical_inside(root, file + ".gz", &gz_escaped);
    if (!gz.empty() && !regular_file(gz)) gz.clear();
  }
  const bool has_range = req.has_header("Range");
  const bool use_gz = !gz.empty() && !has_range && accepts_gzip(accept_encoding);
  const std::string& served = use_gz ? gz : file;

  struct stat st {};
  if (::stat(served.c_str(), &st) != 0) return refuse(404);
  const auto size = static_cast<uint64_t>(st.st_size);
  const uint64_t mtime_ns = static_cast<uint64_t>(st.st_mtim.tv_sec) * 1000000000ull +
                            static_cast<uint64_t>(st.st_mtim.tv_nsec);
  char etag_text[64];
  std::snprintf(etag_text, sizeof etag_text, "\"%" PRIx64 "-%" PRIx64 "%s\"", size, mtime_ns,
                use_gz ? "-gz" : "");
  const std::string etag = etag_text;

  res.set_header("ETag", etag);
  res.set_header("Cache-Control", is_content_hashed(name) ? kImmutable : kNoCache);
  res.set_header("Accept-Ranges", "bytes");
  if (!gz.empty()) res.set_header("Vary", "Accept-Encoding");
  const std::string type = mime_type(name);

  if (req.has_header("If-None-Match") &&
      etag_matches(req.get_header_value("If-None-Match"), etag)) {
    res.status = 304;
    return;
  }

  uint64_t first = 0, last = size == 0 ? 0 : size - 1;
  RangeKind range = RangeKind::kNone;
  if (has_range) {
    const std::string if_range = req.get_header_value("If-Range");
    if (if_range.empty() || if_range == etag) {
      range = parse_range(req.get_header_value("Range"), size, &first, &last);
    }
  }
  if (range == RangeKind::kUnsatisfiable) {
    res.status = 416;
    res.set_header("Content-Range", "bytes */" + std::to_string(size));
    res.set_content("416 range not satisfiable\n", "text/plain; charset=utf-8");
    return;
  }
  std::string body;
  const uint64_t length = size == 0 ? 0 : last - first + 1;
  if (!read_slice(served, first, length, &body)) return refuse(404);
  if (range == RangeKind::kSingle) {
    res.status = 206;
    res.set_header("Content-Range", "bytes " + std::to_string(first) + "-" + std::to_string(last) +
                                        "/" + std::to_string(size));
  } else {
    res.status = 200;
  }
  if (use_gz) res.set_header("Content-Encoding", "gzip");
  res.set_content(std::move(body), type.c_str());
}

void FileServer::Impl::log(const httplib::Request& req, const httplib::Response& res) const {
  double ms = 0;
  if (t_request_started) {
    ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                   t_request_start)
             .count();
    t_request_started = false;
  }
  if (!options.log) return;
  char timing[32];
  std::snprintf(timing, sizeof timing, "%.1f ms", ms);
  options.log(printable(req.method) + " " + printable(req.target) + " " +
              std::to_string(res.status) + " " + std::to_string(res.body.size()) + " B " + timing);
}

FileServer::FileServer() : impl_(std::make_unique<Impl>()) {}

FileServer::~FileServer() {
  stop();
}

Status FileServer::start(const ServeOptions& options) {
  if (running()) return Status(ErrorCode::kInvalidArgument, "serve: the server is already running");
  std::error_code ec;
  if (!fs::exists(options.root, ec)) {
    return Status(ErrorCode::kInvalidArgument, options.root + ": no such folder");
  }
  if (!fs::is_directory(options.root, ec)) {
    return Status(ErrorCode::kInvalidArgument, options.root + ": not a folder");
  }
  if (options.port < 0 || options.port > 65535) {
    return Status(ErrorCode::kInvalidArgument,
                  "serve: port " + std::to_string(options.port) + " is out of range 0..65535");
  }
  Impl& impl = *impl_;
  impl.options = options;
  impl.root = fs::canonical(options.root, ec).string();
  if (ec) return Status(ErrorCode::kIoError, options.root + ": " + ec.message());

  impl.server = std::make_unique<httplib::Server>();
  httplib::Server& server = *impl.server;
  const size_t threads = static_cast<size_t>(std::max(1, options.threads));
  server.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  server.set_keep_alive_max_count(static_cast<size_t>(std::max(1, options.keep_alive_requests)));
  server.set_keep_alive_timeout(std::max(1, options.keep_alive_seconds));
  server.set_read_timeout(5, 0);
  // httplib leaves Nagle's algorithm on: a small response then waits for the client's delayed
  // ACK (about 40 ms per request on a kept-alive connection, most of a 237-file page load).
  server.set_tcp_nodelay(true);
  server.set_write_timeout(5, 0);
  server.set_pre_routing_handler([](const httplib::Request&, httplib::Response&) {
    t_request_start = std::chrono::steady_clock::now();
    t_request_started = true;
    return httplib::Server::HandlerResponse::Unhandled;
  });
  const Impl* self = &impl;
  server.Get(".*", [self](const httplib::Request& req, httplib::Response& res) {
    self->handle(req, res);
  });
  server.set_logger(
      [self](const httplib::Request& req, const httplib::Response& res) { self->log(req, res); });

  // httplib's default socket options add SO_REUSEPORT, which would let a second server share a
  // busy port instead of failing; keep only SO_REUSEADDR (a restarted server rebinds at once), and
  // remember the socket so its listen backlog can be raised (httplib listens with a backlog of 5).
  auto listen_fd = std::make_shared<int>(-1);
  server.set_socket_options([listen_fd](auto sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    *listen_fd = sock;
  });
  int bound = -1;
  if (options.port == 0) {
    bound = server.bind_to_any_port(options.host);
  } else if (server.bind_to_port(options.host, options.port)) {
    bound = options.port;
  }
  if (bound <= 0) {
    impl.server.reset();
    return Status(ErrorCode::kIoError,
                  "cannot listen on " + options.host + " port " + std::to_string(options.port) +
                      ": the port is in use or the address is not available here");
  }
  if (*listen_fd >= 0) ::listen(*listen_fd, SOMAXCONN);
  impl.port = bound;
  impl.listening_done = false;
  impl.thread = std::thread([&impl] {
    impl.server->listen_after_bind();
    impl.listening_done = true;
  });
  // stop() only reaches a server whose loop has started: wait for it.
  while (!server.is_running() && !impl.listening_done) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (!server.is_running()) {
    stop();
    return Status(ErrorCode::kIoError, "serve: the server loop ended at once on " + options.host +
                                           " port " + std::to_string(bound));
  }
  return Status::ok_status();
}

int FileServer::port() const {
  return impl_->port;
}

bool FileServer::running() const {
  return impl_->server != nullptr && impl_->server->is_running();
}

void FileServer::stop() {
  Impl& impl = *impl_;
  if (!impl.server) return;
  impl.server->stop();
  if (impl.thread.joinable()) impl.thread.join();
  impl.server.reset();
}

}  // namespace osteon
