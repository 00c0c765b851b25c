// SPDX-License-Identifier: Apache-2.0
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "osteon/volume.hpp"
#include "volume_fuzz_input.hpp"

// Based on: libFuzzer's LLVMFuzzerTestOneInput contract, like read_fuzzer.cpp: one binary per
// volume format (OSTEON_FUZZ_VOLUME = nii, niigz, nrrd, nhdr). Each input is written to a scratch
// folder (volume_fuzz_input.hpp) and read back with read_volume, with a threshold for inputs of
// odd size so the intensity path runs too. Beyond sanitizer findings, a LabelVolume that breaks
// its promises or an error whose message does not start with the file's path aborts the run.

#ifndef OSTEON_FUZZ_VOLUME
#error "build with -DOSTEON_FUZZ_VOLUME=\"nii\" (or niigz, nrrd, nhdr)"
#endif

namespace {

[[noreturn]] void contract_broken(const char* what, const std::string& detail) {
  std::fprintf(stderr, "osteon fuzz: %s: %s\n", what, detail.c_str());
  std::abort();
}

const std::string& scratch() {
  static const std::string dir = [] {
    char pattern[] = "/tmp/osteon_volume_fuzz_XXXXXX";
    const char* made = mkdtemp(pattern);
    if (made == nullptr) contract_broken("cannot make a scratch folder", pattern);
    return std::string(made);
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path =
      osteon::fuzz::write_volume_input(scratch(), OSTEON_FUZZ_VOLUME, data, size);
  if (path.empty()) contract_broken("cannot write the input", scratch());
  osteon::VolumeReadOptions options;
  options.max_voxel_bytes = uint64_t{64} << 20;
  if (size % 2 == 1) options.threshold = 100;
  auto volume = osteon::read_volume(path, options);
  if (!volume.ok()) {
    const std::string& message = volume.status().message();
    if (message.rfind(path + ": ", 0) != 0) contract_broken("message without source", message);
    return 0;
  }
  const std::string broken = osteon::fuzz::volume_contract_broken(*volume);
  if (!broken.empty()) contract_broken(broken.c_str(), path);
  return 0;
}
