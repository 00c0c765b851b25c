// SPDX-License-Identifier: Apache-2.0
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "seg_fuzz_check.hpp"

// Based on: libFuzzer's LLVMFuzzerTestOneInput contract, like read_fuzzer.cpp: any bytes are
// handed to parse_seg as a .seg file of a mesh with one face per non-blank line, and what parses
// is scored by the segmentation evaluator (seg_fuzz_check.hpp). Beyond sanitizer findings, the
// run aborts on an error whose message does not start with the source name, on labels of the
// wrong count, and on a score that is not finite or lies outside its range.

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string source = "fuzz.seg";
  const osteon::fuzz::SegFuzzOutcome outcome = osteon::fuzz::seg_fuzz_one(data, size, source);
  if (!outcome.broken.empty()) {
    std::fprintf(stderr, "osteon fuzz: %s\n", outcome.broken.c_str());
    std::abort();
  }
  return 0;
}
