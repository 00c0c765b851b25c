// SPDX-License-Identifier: Apache-2.0
#include "osteon/status.hpp"

#include <gtest/gtest.h>

namespace osteon {
namespace {
namespace status_test {

Result<int> half(int x) {
  if (x % 2 != 0)
    return error(ErrorCode::kInvalidArgument, "half", "odd", "value " + std::to_string(x));
  return x / 2;
}

Result<int> quarter(int x) {
  OSTEON_ASSIGN_OR_RETURN(int h, half(x));
  OSTEON_ASSIGN_OR_RETURN(int q, half(h));
  return q;
}

Status check_even(int x) {
  OSTEON_RETURN_IF_ERROR(half(x).status());
  return {};
}

TEST(Status, MessageNamesFileWhatAndWhere) {
  Status s = error(ErrorCode::kInvalidData, "bone.stl", "file is truncated", "byte 84");
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.code(), ErrorCode::kInvalidData);
  EXPECT_EQ(s.message(), "bone.stl: file is truncated (byte 84)");
  EXPECT_EQ(error(ErrorCode::kIoError, "a.ply", "cannot open").message(), "a.ply: cannot open");
  EXPECT_TRUE(Status().ok());
}

TEST(Status, MacrosPropagateTheFirstError) {
  EXPECT_EQ(quarter(8).value(), 2);
  Result<int> r = quarter(6);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().message(), "half: odd (value 3)");
  EXPECT_TRUE(check_even(4).ok());
  EXPECT_EQ(check_even(5).code(), ErrorCode::kInvalidArgument);
}

}  // namespace status_test
}  // namespace
}  // namespace osteon
