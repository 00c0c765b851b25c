// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cstdlib>
#include <string>

// Raw HTTP/1.1 on loopback for the server's tests and its bench (bench/serve_bench.cpp): requests sent byte for byte as given (no
// client-side normalisation or escaping), from a chosen loopback source address (127.0.0.0/8 is
// all loopback on Linux, so "other clients" can be told apart by address), with bounded waits.

namespace osteon::test {

/// A socket connected to 127.0.0.1:port from `source` (e.g. "127.0.0.2"); -1 on failure.
inline int connect_loopback(int port, const char* source = "127.0.0.1") {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_in from{};
  from.sin_family = AF_INET;
  inet_pton(AF_INET, source, &from.sin_addr);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(port));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (bind(fd, reinterpret_cast<sockaddr*>(&from), sizeof from) != 0 ||
      connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

inline bool send_all(int fd, const std::string& bytes) {
  size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return false;
    sent += size_t(n);
  }
  return true;
}

/// Reads until the peer closes or `timeout_ms` passes; returns what arrived.
inline std::string read_until_close(int fd, int timeout_ms) {
  std::string out;
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  char buffer[65536];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          end - std::chrono::steady_clock::now())
                          .count();
    if (left <= 0) break;
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left)) <= 0) break;
    const ssize_t n = recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) break;
    out.append(buffer, size_t(n));
  }
  return out;
}

/// True when the peer has closed (or reset) the connection within `timeout_ms`.
inline bool closed_by_peer(int fd, int timeout_ms) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  char buffer[4096];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          end - std::chrono::steady_clock::now())
                          .count();
    if (left <= 0) return false;
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left)) <= 0) return false;
    const ssize_t n = recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) return true;
  }
}

/// Sends `request` on a fresh connection and returns the whole response (the server closes, or
/// 5 s pass); "" when the connection fails.
inline std::string raw_exchange(int port, const std::string& request,
                                const char* source = "127.0.0.1") {
  const int fd = connect_loopback(port, source);
  if (fd < 0) return {};
  std::string response;
  if (send_all(fd, request)) response = read_until_close(fd, 5000);
  close(fd);
  return response;
}

/// The status code of a response ("HTTP/1.1 405 ..." -> 405), or -1.
inline int status_of(const std::string& response) {
  if (response.size() < 12 || response.compare(0, 5, "HTTP/") != 0) return -1;
  return std::atoi(response.c_str() + 9);
}

/// The value of header `name` (any case) in a raw response; "" when absent.
inline std::string header_of(const std::string& response, const std::string& name) {
  const size_t head_end = response.find("\r\n\r\n");
  std::string head = response.substr(0, head_end);
  std::string key = "\r\n" + name + ": ";
  for (std::string* s : {&head, &key}) {
    for (char& c : *s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  const std::string original = response.substr(0, head_end);
  const size_t at = head.find(key);
  if (at == std::string::npos) return {};
  const size_t start = at + key.size();
  return original.substr(start, head.find("\r\n", start) - start);
}

/// The body of a raw response (after the blank line).
inline std::string body_of(const std::string& response) {
  const size_t head_end = response.find("\r\n\r\n");
  return head_end == std::string::npos ? std::string() : response.substr(head_end + 4);
}

}  // namespace osteon::test
