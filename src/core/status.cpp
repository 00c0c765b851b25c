// SPDX-License-Identifier: Apache-2.0
#include "osteon/status.hpp"

namespace osteon {

Status error(ErrorCode code, const std::string& file, const std::string& what,
             const std::string& where) {
  std::string message = file.empty() ? what : file + ": " + what;
  if (!where.empty()) message += " (" + where + ")";
  return Status(code, std::move(message));
}

}  // namespace osteon
