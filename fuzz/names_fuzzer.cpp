// SPDX-License-Identifier: Apache-2.0
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "names_fuzz_check.hpp"

// Based on: libFuzzer's LLVMFuzzerTestOneInput contract, like manifest_fuzzer.cpp: any bytes are
// handed to parse_names as a names file (a JSON array, {"languages", "parts"}, a JSON object or
// a CSV, as read_names reads them). Beyond sanitizer findings, the run aborts on an error whose
// message does not start with the source name, and on Names that break what read_names promises:
// path groups named, at most kMaxGroupDepth deep, none twice in a path; languages unique and
// listed for every name (names_fuzz_check.hpp).

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string source = "fuzz/names.csv";
  const osteon::fuzz::NamesFuzzOutcome outcome = osteon::fuzz::names_fuzz_one(data, size, source);
  if (!outcome.broken.empty()) {
    std::fprintf(stderr, "osteon fuzz: %s\n", outcome.broken.c_str());
    std::abort();
  }
  return 0;
}
