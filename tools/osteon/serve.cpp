// SPDX-License-Identifier: Apache-2.0
#include "serve.hpp"

#include <fcntl.h>
#include <malloc.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <thread>
#include <unordered_set>
#include <utility>
#include <vector>

#include <microhttpd.h>

// Based on: RFC 9110 sections 8.8.3 (ETag), 13.1.2 (If-None-Match), 14 (Range, Content-Range, 416),
// 12.5.3 (Accept-Encoding), 15.5.6 (405, Allow) and 15.6.4 (503, Retry-After); RFC 9111 section
// 5.2 and RFC 8246 (Cache-Control: immutable). libmicrohttpd parses requests and runs the epoll
// threads; everything a response says, and when a connection has had its time, is decided here.

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

/// Decodes the %XX escapes of a request path. False on a malformed escape ("%zz", "%4").
bool percent_decode(const std::string& in, std::string* out) {
  out->clear();
  out->reserve(in.size());
  for (size_t i = 0; i < in.size(); ++i) {
    if (in[i] != '%') {
      out->push_back(in[i]);
      continue;
    }
    if (i + 2 >= in.size() || !std::isxdigit(static_cast<unsigned char>(in[i + 1])) ||
        !std::isxdigit(static_cast<unsigned char>(in[i + 2]))) {
      return false;
    }
    const char hex[3] = {in[i + 1], in[i + 2], 0};
    out->push_back(static_cast<char>(std::strtol(hex, nullptr, 16)));
    i += 2;
  }
  return true;
}

int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

constexpr int64_t kSecond = 1000000000;

/// What one request gets: a status, headers, and a body that is either `text` or `length` bytes
/// of the open file `fd` from `offset` (the fd is the Reply's until MHD takes it).
struct Reply {
  unsigned status = 200;
  std::vector<std::pair<const char*, std::string>> headers;
  std::string text;
  int fd = -1;
  uint64_t offset = 0;
  uint64_t length = 0;

  Reply() = default;
  Reply(const Reply&) = delete;
  Reply& operator=(const Reply&) = delete;
  ~Reply() {
    if (fd >= 0) ::close(fd);
  }
  void header(const char* name, std::string value) { headers.emplace_back(name, std::move(value)); }
  void plain(unsigned code, const char* body) {
    status = code;
    text = body;
    header(MHD_HTTP_HEADER_CONTENT_TYPE, "text/plain; charset=utf-8");
  }
  uint64_t body_bytes() const { return fd >= 0 ? length : text.size(); }
};

/// One TCP connection (MHD's socket context). `deadline_ns` is when the watchdog cuts it unless a
/// request head has arrived by then (0: no deadline, a request is being answered); `idle` is set
/// between a response and the next request line.
struct Connection {
  int fd = -1;
  std::atomic<int64_t> deadline_ns{0};
  std::atomic<bool> idle{false};
  bool over_cap = false;  // accepted beyond max_connections: answered 503, then closed
  int requests = 0;       // touched only by the connection's own event thread
  bool cut = false;       // touched only by the watchdog, under the connection set's mutex
};

/// One request (MHD's per-request context), from its request line to the end of its response.
struct Exchange {
  std::string target;  // as the client sent it, query included
  // Where the request target lay in MHD's buffer, and its length as a C string: a target with a
  // NUL byte inside is longer than that (see on_request).
  const char* target_start = nullptr;
  size_t target_length = 0;
  std::string method = "-";
  unsigned status = 0;
  uint64_t bytes = 0;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  bool head_seen = false;
  bool answered = false;
};

/// True for 127.0.0.0/8, ::1 and IPv4-mapped loopback addresses.
bool is_loopback(const sockaddr_storage& addr) {
  if (addr.ss_family == AF_INET) {
    const auto& v4 = reinterpret_cast<const sockaddr_in&>(addr);
    return (ntohl(v4.sin_addr.s_addr) >> 24) == 127;
  }
  if (addr.ss_family == AF_INET6) {
    const auto& a = reinterpret_cast<const sockaddr_in6&>(addr).sin6_addr;
    if (IN6_IS_ADDR_LOOPBACK(&a)) return true;
    return IN6_IS_ADDR_V4MAPPED(&a) && a.s6_addr[12] == 127;
  }
  return false;
}

/// A listening TCP socket on host:port (SO_REUSEADDR only, so a busy port is an error; the
/// kernel's largest backlog; non-blocking, as the event loop wants it). -1 on failure, with
/// `*why` saying what failed.
int listen_on(const std::string& host, int port, sockaddr_storage* bound, std::string* why) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  const int gai =
      getaddrinfo(host.empty() ? nullptr : host.c_str(), service.c_str(), &hints, &found);
  if (gai != 0) {
    *why = gai_strerror(gai);
    return -1;
  }
  int fd = -1;
  for (addrinfo* a = found; a != nullptr && fd < 0; a = a->ai_next) {
    fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, a->ai_protocol);
    if (fd < 0) continue;
    const int yes = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) != 0 || ::listen(fd, SOMAXCONN) != 0) {
      *why = std::strerror(errno);
      ::close(fd);
      fd = -1;
    }
  }
  freeaddrinfo(found);
  if (fd < 0) return -1;
  socklen_t len = sizeof *bound;
  if (getsockname(fd, reinterpret_cast<sockaddr*>(bound), &len) != 0) {
    *why = std::strerror(errno);
    ::close(fd);
    return -1;
  }
  return fd;
}

int bound_port(const sockaddr_storage& addr) {
  if (addr.ss_family == AF_INET) return ntohs(reinterpret_cast<const sockaddr_in&>(addr).sin_port);
  if (addr.ss_family == AF_INET6) {
    return ntohs(reinterpret_cast<const sockaddr_in6&>(addr).sin6_port);
  }
  return 0;
}

Connection* connection_of(MHD_Connection* connection) {
  const MHD_ConnectionInfo* info =
      MHD_get_connection_info(connection, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
  return info == nullptr ? nullptr : static_cast<Connection*>(info->socket_context);
}

/// Request line for the log: control characters shown as '?'.
std::string printable(const std::string& s) {
  std::string out = s.substr(0, 512);
  for (char& c : out) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  }
  return out;
}

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
  MHD_Daemon* daemon = nullptr;
  int listen_fd = -1;
  int port = 0;
  std::atomic<int> live{0};  // connections open now

  // Every open connection, for the watchdog that enforces the head and keep-alive deadlines.
  std::mutex connections_mutex;
  std::unordered_set<Connection*> connections;
  std::thread watchdog;
  std::mutex stop_mutex;
  std::condition_variable stop_signal;
  bool stopping = false;

  /// Decides the reply to `method url` (url: the raw path, query removed).
  void answer(MHD_Connection* connection, const std::string& method, const char* url,
              Reply* reply) const;
  void watch();

  static MHD_Result on_request(void* cls, MHD_Connection* connection, const char* url,
                               const char* method, const char* version, const char* upload_data,
                               size_t* upload_data_size, void** request_context);
  static void on_completed(void* cls, MHD_Connection* connection, void** request_context,
                           MHD_RequestTerminationCode code);
  static void* on_request_line(void* cls, const char* uri, MHD_Connection* connection);
  static void on_connection(void* cls, MHD_Connection* connection, void** socket_context,
                            MHD_ConnectionNotificationCode code);
  static size_t keep_escapes(void* cls, MHD_Connection* connection, char* s);
};

void FileServer::Impl::answer(MHD_Connection* connection, const std::string& method,
                              const char* url_text, Reply* reply) const {
  Reply& res = *reply;
  if (method != MHD_HTTP_METHOD_GET && method != MHD_HTTP_METHOD_HEAD) {
    res.header(MHD_HTTP_HEADER_ALLOW, "GET, HEAD");
    return res.plain(MHD_HTTP_METHOD_NOT_ALLOWED, "405 method not allowed: GET and HEAD only\n");
  }
  auto refuse = [&res](unsigned status) {
    res.plain(status, status == MHD_HTTP_FORBIDDEN ? "403 forbidden\n" : "404 not found\n");
  };
  const std::string raw = url_text;  // not yet percent-decoded (keep_escapes)
  // Origin-form only: an absolute URI ("http://host/x") or "*" names no file of this folder.
  if (raw.empty() || raw[0] != '/' || raw.find('\\') != std::string::npos) {
    return refuse(MHD_HTTP_FORBIDDEN);
  }
  std::string url;
  if (!percent_decode(raw, &url)) {
    return res.plain(MHD_HTTP_BAD_REQUEST, "400 bad request: malformed percent-escape\n");
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
      return refuse(MHD_HTTP_FORBIDDEN);
    }
    rel /= seg;
  }

  bool escaped = false;
  std::string file = canonical_inside(root, fs::path(root) / rel, &escaped);
  if (file.empty()) return refuse(escaped ? MHD_HTTP_FORBIDDEN : MHD_HTTP_NOT_FOUND);
  std::error_code ec;
  if (fs::is_directory(file, ec)) {
    file = canonical_inside(root, fs::path(file) / "index.html", &escaped);
    if (file.empty()) return refuse(escaped ? MHD_HTTP_FORBIDDEN : MHD_HTTP_NOT_FOUND);
  }
  if (!regular_file(file)) return refuse(MHD_HTTP_NOT_FOUND);
  const std::string name = fs::path(file).filename().string();
  auto header = [connection](const char* key) -> const char* {
    return MHD_lookup_connection_value(connection, MHD_HEADER_KIND, key);
  };

  // The precompressed sibling X.gz, when there is one inside root.
  std::string gz;
  if (name.size() < 3 || name.compare(name.size() - 3, 3, ".gz") != 0) {
    bool gz_escaped = false;
    gz = canonical_inside(root, file + ".gz", &gz_escaped);
    if (!gz.empty() && !regular_file(gz)) gz.clear();
  }
  const char* range_header = header(MHD_HTTP_HEADER_RANGE);
  const char* accept_encoding = header(MHD_HTTP_HEADER_ACCEPT_ENCODING);
  const bool use_gz = !gz.empty() && range_header == nullptr && accept_encoding != nullptr &&
                      accepts_gzip(accept_encoding);
  const std::string& served = use_gz ? gz : file;

  // Opened, then described by fstat: the ETag names the bytes this descriptor will send. The
  // path is canonical, so O_NOFOLLOW only refuses a symlink swapped in since.
  const int fd = ::open(served.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) return refuse(MHD_HTTP_NOT_FOUND);
  res.fd = fd;
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) return refuse(MHD_HTTP_NOT_FOUND);
  const auto size = static_cast<uint64_t>(st.st_size);
  const uint64_t mtime_ns = static_cast<uint64_t>(st.st_mtim.tv_sec) * 1000000000ull +
                            static_cast<uint64_t>(st.st_mtim.tv_nsec);
  char etag_text[64];
  std::snprintf(etag_text, sizeof etag_text, "\"%" PRIx64 "-%" PRIx64 "%s\"", size, mtime_ns,
                use_gz ? "-gz" : "");
  const std::string etag = etag_text;

  res.header(MHD_HTTP_HEADER_ETAG, etag);
  res.header(MHD_HTTP_HEADER_CACHE_CONTROL, is_content_hashed(name) ? kImmutable : kNoCache);
  res.header(MHD_HTTP_HEADER_ACCEPT_RANGES, "bytes");
  if (!gz.empty()) res.header(MHD_HTTP_HEADER_VARY, "Accept-Encoding");

  const char* if_none_match = header(MHD_HTTP_HEADER_IF_NONE_MATCH);
  if (if_none_match != nullptr && etag_matches(if_none_match, etag)) {
    res.status = MHD_HTTP_NOT_MODIFIED;
    ::close(res.fd);
    res.fd = -1;
    return;
  }

  uint64_t first = 0, last = size == 0 ? 0 : size - 1;
  RangeKind range = RangeKind::kNone;
  if (range_header != nullptr) {
    const char* if_range = header(MHD_HTTP_HEADER_IF_RANGE);
    if (if_range == nullptr || if_range == etag) {
      range = parse_range(range_header, size, &first, &last);
    }
  }
  if (range == RangeKind::kUnsatisfiable) {
    ::close(res.fd);
    res.fd = -1;
    res.header(MHD_HTTP_HEADER_CONTENT_RANGE, "bytes */" + std::to_string(size));
    return res.plain(MHD_HTTP_RANGE_NOT_SATISFIABLE, "416 range not satisfiable\n");
  }
  if (range == RangeKind::kSingle) {
    res.status = MHD_HTTP_PARTIAL_CONTENT;
    res.header(
        MHD_HTTP_HEADER_CONTENT_RANGE,
        "bytes " + std::to_string(first) + "-" + std::to_string(last) + "/" + std::to_string(size));
  } else {
    res.status = MHD_HTTP_OK;
  }
  res.offset = first;
  res.length = size == 0 ? 0 : last - first + 1;
  res.header(MHD_HTTP_HEADER_CONTENT_TYPE, mime_type(name));
  if (use_gz) res.header(MHD_HTTP_HEADER_CONTENT_ENCODING, "gzip");
}

MHD_Result FileServer::Impl::on_request(void* cls, MHD_Connection* connection, const char* url,
                                        const char* method, const char* version,
                                        const char* /*upload_data*/, size_t* upload_data_size,
                                        void** request_context) {
  const Impl& impl = *static_cast<const Impl*>(cls);
  auto* exchange = static_cast<Exchange*>(*request_context);
  if (exchange == nullptr) {  // on_request_line always runs first; kept for safety
    exchange = new Exchange;
    exchange->target = url;
    *request_context = exchange;
  }
  if (exchange->answered) {  // the body of a request already answered (405): discarded
    *upload_data_size = 0;
    return MHD_YES;
  }
  Connection* conn = connection_of(connection);
  Reply reply;
  // MHD calls once when the head is in, then per piece of body, then once more when the request
  // is complete. A response queued on the first call is an early one: MHD sends it, discards
  // any body and closes the connection. That suits refusals; a file is answered on the last call,
  // so the connection stays open for the next request. The head deadline runs until then, so it
  // bounds a body trickled after the head too.
  if (!exchange->head_seen) {
    exchange->head_seen = true;
    exchange->method = method;
    // MHD hands the target over as a C string, so a raw NUL byte in it ("GET /index.html\0.png")
    // would end it early and the rest would go unseen. The version follows the target and one
    // space in the same buffer: a gap between the two means a NUL inside the target.
    const auto start = reinterpret_cast<uintptr_t>(exchange->target_start);
    const auto at_version = reinterpret_cast<uintptr_t>(version);
    const bool nul_inside = start != 0 && at_version > start &&
                            at_version - start - 1 > exchange->target_length && *version != '\0';
    if (nul_inside) {
      reply.plain(MHD_HTTP_BAD_REQUEST, "400 bad request: NUL byte in the request target\n");
    } else if (conn != nullptr && conn->over_cap) {
      reply.header(MHD_HTTP_HEADER_RETRY_AFTER, "1");
      reply.plain(MHD_HTTP_SERVICE_UNAVAILABLE, "503 busy: too many connections, retry shortly\n");
    } else if (exchange->method != MHD_HTTP_METHOD_GET &&
               exchange->method != MHD_HTTP_METHOD_HEAD) {
      impl.answer(connection, exchange->method, url, &reply);  // 405
    } else {
      return MHD_YES;
    }
  } else if (*upload_data_size != 0) {  // a body sent with GET or HEAD: read and ignored
    *upload_data_size = 0;
    return MHD_YES;
  } else {
    impl.answer(connection, exchange->method, url, &reply);
  }
  exchange->answered = true;
  exchange->start = std::chrono::steady_clock::now();
  bool close_after = reply.status == MHD_HTTP_SERVICE_UNAVAILABLE;
  if (conn != nullptr) {
    conn->deadline_ns = 0;  // the request is in: MHD's idle timeout watches the response
    ++conn->requests;
    close_after = close_after || conn->requests >= impl.options.keep_alive_requests;
  }
  exchange->status = reply.status;
  exchange->bytes = reply.body_bytes();
  MHD_Response* response = nullptr;
  if (reply.fd >= 0 && reply.length > 0) {
    response = MHD_create_response_from_fd_at_offset64(reply.length, reply.fd,
                                                       static_cast<int64_t>(reply.offset));
    if (response != nullptr) reply.fd = -1;  // MHD closes it with the response
  } else {
    response = MHD_create_response_from_buffer(reply.text.size(), reply.text.data(),
                                               MHD_RESPMEM_MUST_COPY);
  }
  if (response == nullptr) return MHD_NO;
  for (const auto& [name, value] : reply.headers) {
    MHD_add_response_header(response, name, value.c_str());
  }
  if (close_after) MHD_add_response_header(response, MHD_HTTP_HEADER_CONNECTION, "close");
  const MHD_Result queued = MHD_queue_response(connection, reply.status, response);
  MHD_destroy_response(response);
  return queued;
}

void FileServer::Impl::on_completed(void* cls, MHD_Connection* connection, void** request_context,
                                    MHD_RequestTerminationCode code) {
  const Impl& impl = *static_cast<const Impl*>(cls);
  auto* exchange = static_cast<Exchange*>(*request_context);
  *request_context = nullptr;
  if (Connection* conn = connection_of(connection)) {
    conn->idle = true;
    conn->deadline_ns = now_ns() + impl.options.keep_alive_seconds * kSecond;
  }
  if (exchange == nullptr) return;
  if (impl.options.log) {
    unsigned status = exchange->status;
    if (!exchange->answered) {  // refused by the HTTP parser, which answered by itself
      const MHD_ConnectionInfo* info =
          MHD_get_connection_info(connection, MHD_CONNECTION_INFO_HTTP_STATUS);
      status = info != nullptr ? info->http_status : 0;
    }
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                                exchange->start)
                          .count();
    char tail[64];
    std::snprintf(
        tail, sizeof tail, " B %.1f ms%s", ms,
        code == MHD_REQUEST_TERMINATED_COMPLETED_OK || !exchange->answered ? "" : ", aborted");
    impl.options.log(printable(exchange->method) + " " + printable(exchange->target) + " " +
                     std::to_string(status) + " " + std::to_string(exchange->bytes) + tail);
  }
  delete exchange;
}

void* FileServer::Impl::on_request_line(void* cls, const char* uri, MHD_Connection* connection) {
  const Impl& impl = *static_cast<const Impl*>(cls);
  // A keep-alive connection's next request has begun: its head gets the full head deadline.
  Connection* conn = connection_of(connection);
  if (conn != nullptr && conn->idle.exchange(false)) {
    conn->deadline_ns = now_ns() + impl.options.header_timeout_seconds * kSecond;
  }
  auto* exchange = new Exchange;
  exchange->target = uri;
  exchange->target_start = uri;
  exchange->target_length = exchange->target.size();
  return exchange;
}

void FileServer::Impl::on_connection(void* cls, MHD_Connection* connection, void** socket_context,
                                     MHD_ConnectionNotificationCode code) {
  Impl& impl = *static_cast<Impl*>(cls);
  if (code == MHD_CONNECTION_NOTIFY_STARTED) {
    auto* conn = new Connection;
    const MHD_ConnectionInfo* info =
        MHD_get_connection_info(connection, MHD_CONNECTION_INFO_CONNECTION_FD);
    conn->fd = info != nullptr ? info->connect_fd : -1;
    conn->deadline_ns = now_ns() + impl.options.header_timeout_seconds * kSecond;
    conn->over_cap = impl.live.fetch_add(1) + 1 > impl.options.max_connections;
    std::lock_guard<std::mutex> lock(impl.connections_mutex);
    impl.connections.insert(conn);
    *socket_context = conn;
    return;
  }
  auto* conn = static_cast<Connection*>(*socket_context);
  if (conn == nullptr) return;
  // MHD notifies before it closes the socket, so the watchdog, under this mutex, never shuts
  // down a descriptor that has been closed (and possibly reused).
  {
    std::lock_guard<std::mutex> lock(impl.connections_mutex);
    impl.connections.erase(conn);
  }
  impl.live.fetch_sub(1);
  delete conn;
  *socket_context = nullptr;
}

size_t FileServer::Impl::keep_escapes(void*, MHD_Connection*, char* s) {
  // MHD would percent-decode the path into a C string, where "%00" ends it early
  // ("/index.html%00.png" would become "/index.html"); answer() decodes it instead.
  return std::strlen(s);
}

void FileServer::Impl::watch() {
  std::unique_lock<std::mutex> lock(stop_mutex);
  int tick = 0;
  int most = 0;  // the most connections open at once since the heap was last trimmed
  while (!stopping) {
    stop_signal.wait_for(lock, std::chrono::milliseconds(100));
    // Each connection's memory pool is heap memory that glibc keeps after the connection closes:
    // after a burst (a thousand trickling connections, say) hand it back, so that resident
    // memory follows the connections open now rather than the most there ever were.
    most = std::max(most, live.load());
    if (++tick % 50 == 0 && most > 64 && live.load() < most / 2) {
      malloc_trim(0);
      most = live.load();
    }
    const int64_t now = now_ns();
    std::lock_guard<std::mutex> guard(connections_mutex);
    for (Connection* conn : connections) {
      const int64_t deadline = conn->deadline_ns.load();
      if (deadline == 0 || now < deadline || conn->cut || conn->fd < 0) continue;
      // The event loop sees end-of-stream on its next read and closes the connection itself.
      ::shutdown(conn->fd, SHUT_RDWR);
      conn->cut = true;
    }
  }
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
  if (options.threads < 1 || options.max_connections < 1 || options.max_per_client < -1 ||
      options.header_timeout_seconds < 1 || options.keep_alive_seconds < 1 ||
      options.keep_alive_requests < 1 || options.idle_timeout_seconds < 1) {
    return Status(ErrorCode::kInvalidArgument,
                  "serve: threads, limits and timeouts must be positive (max_per_client: -1, 0 "
                  "or more)");
  }
  Impl& impl = *impl_;
  impl.options = options;
  impl.root = fs::canonical(options.root, ec).string();
  if (ec) return Status(ErrorCode::kIoError, options.root + ": " + ec.message());

  sockaddr_storage bound{};
  std::string why;
  impl.listen_fd = listen_on(options.host, options.port, &bound, &why);
  if (impl.listen_fd < 0) {
    return Status(ErrorCode::kIoError,
                  "cannot listen on " + options.host + " port " + std::to_string(options.port) +
                      ": the port is in use or the address is not available here (" + why + ")");
  }
  impl.port = bound_port(bound);

  // Connections beyond max_connections, up to this, are accepted to be told 503.
  const auto cap = static_cast<unsigned>(options.max_connections);
  const unsigned hard_limit = cap + std::max(8u, cap / 8);
  const unsigned per_client = options.max_per_client >= 0 ? unsigned(options.max_per_client)
                              : is_loopback(bound)        ? 0u
                                                          : 64u;
  // Each connection holds its socket and, while a file is sent, the file's descriptor.
  rlimit files{};
  if (getrlimit(RLIMIT_NOFILE, &files) == 0) {
    const rlim_t want = 2 * rlim_t(hard_limit) + 64;
    if (files.rlim_cur != RLIM_INFINITY && files.rlim_cur < want) {
      files.rlim_cur = files.rlim_max == RLIM_INFINITY ? want : std::min(want, files.rlim_max);
      setrlimit(RLIMIT_NOFILE, &files);
    }
  }

  impl.stopping = false;
  impl.live = 0;
  const unsigned threads = static_cast<unsigned>(options.threads);
  impl.daemon = MHD_start_daemon(
      MHD_USE_EPOLL_INTERNAL_THREAD, 0, nullptr, nullptr, &Impl::on_request, &impl,
      MHD_OPTION_LISTEN_SOCKET, static_cast<MHD_socket>(impl.listen_fd),
      MHD_OPTION_THREAD_POOL_SIZE, threads > 1 ? threads : 0u, MHD_OPTION_CONNECTION_LIMIT,
      hard_limit, MHD_OPTION_PER_IP_CONNECTION_LIMIT, per_client, MHD_OPTION_CONNECTION_TIMEOUT,
      static_cast<unsigned>(options.idle_timeout_seconds), MHD_OPTION_NOTIFY_CONNECTION,
      &Impl::on_connection, &impl, MHD_OPTION_URI_LOG_CALLBACK, &Impl::on_request_line, &impl,
      MHD_OPTION_NOTIFY_COMPLETED, &Impl::on_completed, &impl, MHD_OPTION_UNESCAPE_CALLBACK,
      &Impl::keep_escapes, &impl, MHD_OPTION_END);
  if (impl.daemon == nullptr) {
    ::close(impl.listen_fd);
    impl.listen_fd = -1;
    return Status(ErrorCode::kIoError, "serve: the HTTP event loop did not start on " +
                                           options.host + " port " + std::to_string(impl.port));
  }
  impl.watchdog = std::thread([&impl] { impl.watch(); });
  return Status::ok_status();
}

int FileServer::port() const {
  return impl_->port;
}

bool FileServer::running() const {
  return impl_->daemon != nullptr;
}

void FileServer::stop() {
  Impl& impl = *impl_;
  if (impl.daemon == nullptr) return;
  {
    std::lock_guard<std::mutex> lock(impl.stop_mutex);
    impl.stopping = true;
  }
  impl.stop_signal.notify_all();
  if (impl.watchdog.joinable()) impl.watchdog.join();
  MHD_stop_daemon(impl.daemon);  // closes the connections and the listening socket
  impl.daemon = nullptr;
  impl.listen_fd = -1;
}

}  // namespace osteon
