// SPDX-License-Identifier: Apache-2.0
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "manifest_fuzz_check.hpp"

// Based on: libFuzzer's LLVMFuzzerTestOneInput contract, like read_fuzzer.cpp: any bytes are
// handed to parse_manifest as a manifest.json text (no chunk file is opened). Beyond sanitizer
// findings, the run aborts on an error whose message does not start with the source name, on a
// Manifest that breaks what parse_manifest promises, and on one that write_manifest cannot write
// back: its text must parse again and give the same text (manifest_fuzz_check.hpp).

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string source = "fuzz/manifest.json";
  const osteon::fuzz::ManifestFuzzOutcome outcome =
      osteon::fuzz::manifest_fuzz_one(data, size, source);
  if (!outcome.broken.empty()) {
    std::fprintf(stderr, "osteon fuzz: %s\n", outcome.broken.c_str());
    std::abort();
  }
  return 0;
}
