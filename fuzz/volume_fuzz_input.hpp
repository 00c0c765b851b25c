// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "osteon/volume.hpp"

// How a volume fuzz input becomes files, and what a LabelVolume must hold: shared by
// fuzz/volume_fuzzer.cpp and the corpus replay in tests/fuzz_corpus_test.cpp, so both read each
// input the same way. read_volume takes a path (libnifti reads the header from the file), so the
// bytes go to a scratch folder first.
//
// Formats, one fuzz target each: "nii" (fuzz.nii), "niigz" (fuzz.nii.gz, the input as it is:
// gzip seeds), "nrrd" (fuzz.nrrd), "nhdr" (the input up to its first blank line is fuzz.nhdr, the
// rest fuzz.raw, which the header may name as its data file).

namespace osteon::fuzz {

inline std::string volume_file_name(const std::string& format) {
  if (format == "niigz") return "fuzz.nii.gz";
  return "fuzz." + format;
}

inline bool write_whole(const std::string& path, const uint8_t* data, size_t size) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) return false;
  const bool ok = std::fwrite(data, 1, size, file) == size;
  return std::fclose(file) == 0 && ok;
}

/// Writes one input as the files of `format` in `dir`; returns the path to read ("" on failure).
inline std::string write_volume_input(const std::string& dir, const std::string& format,
                                      const uint8_t* data, size_t size) {
  const std::string path = dir + "/" + volume_file_name(format);
  const std::string raw = dir + "/fuzz.raw";
  std::remove(raw.c_str());
  if (format == "nhdr") {
    std::string_view text(reinterpret_cast<const char*>(data), size);
    const size_t blank = text.find("\n\n");
    const size_t header = blank == std::string_view::npos ? size : blank + 1;
    if (!write_whole(path, data, header)) return "";
    if (blank != std::string_view::npos && !write_whole(raw, data + blank + 2, size - blank - 2)) {
      return "";
    }
    return path;
  }
  return write_whole(path, data, size) ? path : "";
}

/// "" when `v` keeps LabelVolume's promises, else the promise it breaks.
inline std::string volume_contract_broken(const LabelVolume& v) {
  if (v.bytes_per_voxel != 1 && v.bytes_per_voxel != 2) return "bytes_per_voxel";
  if (v.voxels.size() != v.voxel_count() * size_t(v.bytes_per_voxel)) return "voxels size";
  if (v.values.empty() || v.values[0] != 0) return "values[0]";
  std::vector<uint64_t> counts(v.values.size(), 0);
  for (size_t i = 0; i < v.voxel_count(); ++i) {
    const uint32_t id = v.id(i);
    if (id >= v.values.size()) return "dense id out of range";
    ++counts[id];
  }
  for (size_t i = 0; i < v.table.size(); ++i) {
    if (i > 0 && v.table[i - 1].value >= v.table[i].value) return "table not sorted";
    if (v.table[i].value == 0) return "table names the background";
  }
  for (size_t id = 1; id < v.values.size(); ++id) {
    bool found = false;
    for (const VolumeLabel& label : v.table) {
      if (label.value != v.values[id]) continue;
      found = true;
      if (label.voxels != counts[id]) return "table miscounts a label";
    }
    if (!found) return "a present label missing from the table";
  }
  for (double x : v.index_to_world) {
    if (x != x || x - x != 0) return "index_to_world not finite";
  }
  return "";
}

}  // namespace osteon::fuzz
