// SPDX-License-Identifier: Apache-2.0
#include "osteon/status.hpp"

namespace osteon {

Status error(ErrorCode code, const std::string& file, const std::string& what,
             const std::string& where) {
  // Appends rather than operator+: the WebAssembly decoder's download holds fewer functions.
  std::string message = file;
  if (!message.empty()) message += ": ";
  message += what;
  if (!where.empty()) {
    message += " (";
    message += where;
    message += ")";
  }
  return Status(code, std::move(message));
}

}  // namespace osteon
