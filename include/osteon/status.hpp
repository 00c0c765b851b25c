// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <string>
#include <utility>
#include <variant>

// Based on: Draco's Status/StatusOr and cgltf's single result enum: the library never throws on bad
// data; every fallible call returns a Status or a Result<T> whose message names the file and the
// position ("bone.stl: 120 triangles declared, room for 3 (byte 84)").

namespace osteon {

/// What kind of failure a Status reports. The CLI maps every error to exit code 2.
enum class ErrorCode {
  kOk = 0,
  kIoError,          ///< the file could not be opened, read or written
  kInvalidData,      ///< the bytes are not a valid file of the claimed format
  kUnsupported,      ///< valid, but a feature osteon does not read (e.g. a VTK UNSTRUCTURED_GRID)
  kInvalidArgument,  ///< the caller's options are out of range
};

/// The outcome of an operation: ok, or an error code with a message that names the file and the
/// position (byte offset or line) where the problem was found.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(ErrorCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status ok_status() { return Status(); }

  bool ok() const { return code_ == ErrorCode::kOk; }
  ErrorCode code() const { return code_; }
  const std::string& message() const { return message_; }

 private:
  ErrorCode code_ = ErrorCode::kOk;
  std::string message_;
};

/// Builds an error Status: `error(ErrorCode::kInvalidData, file, "what", "byte 84")` gives the
/// message "file: what (byte 84)". `where` may be empty.
Status error(ErrorCode code, const std::string& file, const std::string& what,
             const std::string& where = {});

/// A value or the Status that explains why there is none.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : data_(std::move(value)) {}         // NOLINT: implicit by design
  Result(Status status) : data_(std::move(status)) {}  // NOLINT: implicit by design

  bool ok() const { return std::holds_alternative<T>(data_); }
  const Status& status() const {
    static const Status kOkStatus;
    return ok() ? kOkStatus : std::get<Status>(data_);
  }
  T& value() & { return std::get<T>(data_); }
  const T& value() const& { return std::get<T>(data_); }
  T&& value() && { return std::get<T>(std::move(data_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }

 private:
  std::variant<T, Status> data_;
};

}  // namespace osteon

#define OSTEON_CONCAT_IMPL(a, b) a##b
#define OSTEON_CONCAT(a, b) OSTEON_CONCAT_IMPL(a, b)

/// Returns the Status of `expr` from the enclosing function when it is not ok.
#define OSTEON_RETURN_IF_ERROR(expr)                 \
  do {                                               \
    ::osteon::Status osteon_status_ = (expr);        \
    if (!osteon_status_.ok()) return osteon_status_; \
  } while (0)

/// `OSTEON_ASSIGN_OR_RETURN(auto x, f())`: declares x from the Result of f() or returns its error.
#define OSTEON_ASSIGN_OR_RETURN(lhs, expr) \
  OSTEON_ASSIGN_OR_RETURN_IMPL(OSTEON_CONCAT(osteon_result_, __LINE__), lhs, expr)
#define OSTEON_ASSIGN_OR_RETURN_IMPL(tmp, lhs, expr) \
  auto tmp = (expr);                                 \
  if (!tmp.ok()) return tmp.status();                \
  lhs = std::move(tmp).value()
