// SPDX-License-Identifier: Apache-2.0
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "regions_fuzz_check.hpp"

// Based on: libFuzzer's LLVMFuzzerTestOneInput contract, like manifest_fuzzer.cpp: the bytes are
// BodyParts3D's three ontology tables joined by NUL bytes, handed to place_by_fma_tables with
// three fixed stems. Beyond sanitizer findings, the run aborts on an error whose message does not
// name one of the tables, and on a placement whose path is neither empty nor "Skeleton / <a
// region of kRegionRules> / ..." as region_path gives it (regions_fuzz_check.hpp).

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = "fuzz";
  const osteon::fuzz::RegionsFuzzOutcome outcome = osteon::fuzz::regions_fuzz_one(data, size, dir);
  if (!outcome.broken.empty()) {
    std::fprintf(stderr, "osteon fuzz: %s\n", outcome.broken.c_str());
    std::abort();
  }
  return 0;
}
