// SPDX-License-Identifier: Apache-2.0
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>

#include "core/byte_io.hpp"
#include "core/weld.hpp"
#include "io_internal.hpp"

// Based on: the STL format as 3D Systems defined it (80-byte header, uint32 count, 50-byte
// records of normal, three vertices and a 2-byte attribute; or "solid ... facet normal ... outer
// loop ... vertex ... endloop endfacet ... endsolid"). Many binary files begin their header with
// "solid" too, so the file size decides first: a file of exactly 84 + 50 * count bytes is binary.

namespace osteon::detail {

namespace {

constexpr size_t kHeaderBytes = 84;
constexpr size_t kRecordBytes = 50;

// Adds binary STL records to a mesh, welding exactly-equal positions as they arrive when a
// welder is given (so a 50-byte-per-triangle soup becomes ~18 bytes per triangle at once).
class BinaryStlSink {
 public:
  BinaryStlSink(Mesh* mesh, uint32_t triangles, bool weld) : mesh_(mesh) {
    mesh_->indices.reserve(size_t{triangles} * 3);
    if (weld) {
      // A closed surface has about half as many vertices as triangles.
      mesh_->positions.reserve(size_t{triangles} / 2 + 8);
      welder_ = std::make_unique<ExactWelder>(&mesh_->positions, size_t{triangles} / 2 + 8);
    } else {
      mesh_->positions.reserve(size_t{triangles} * 3);
    }
  }

  // `records` points at `count` whole records; `offset` is the file offset of the first one.
  Status add(const uint8_t* records, size_t count, size_t offset, const std::string& source) {
    for (size_t r = 0; r < count; ++r) {
      const uint8_t* rec = records + r * kRecordBytes;
      for (int k = 0; k < 3; ++k) {
        const uint8_t* p = rec + 12 + 12 * k;
        Vec3 v{ByteReader::load<float>(p, std::endian::little),
               ByteReader::load<float>(p + 4, std::endian::little),
               ByteReader::load<float>(p + 8, std::endian::little)};
        if (!is_finite(v)) {
          return non_finite_error(source, vertices_seen_,
                                  at_byte(offset + r * kRecordBytes + 12 + 12 * k));
        }
        ++vertices_seen_;
        if (welder_) {
          mesh_->indices.push_back(welder_->insert(v));
        } else {
          mesh_->indices.push_back(static_cast<uint32_t>(mesh_->positions.size()));
          mesh_->positions.push_back(v);
        }
      }
    }
    return {};
  }

 private:
  Mesh* mesh_;
  std::unique_ptr<ExactWelder> welder_;
  size_t vertices_seen_ = 0;
};

bool starts_with_solid(const uint8_t* data, size_t size) {
  size_t i = 0;
  while (i < size && TextReader::is_space(static_cast<char>(data[i]))) ++i;
  return size - i >= 5 && std::memcmp(data + i, "solid", 5) == 0;
}

// An ASCII STL names "facet" soon after "solid"; a binary one whose header happens to begin with
// "solid" has binary noise there instead.
bool looks_ascii(const uint8_t* data, size_t size) {
  if (!starts_with_solid(data, size)) return false;
  std::string_view head(reinterpret_cast<const char*>(data), std::min<size_t>(size, 1024));
  if (head.find('\0') != std::string_view::npos) return false;
  return head.find("facet") != std::string_view::npos ||
         head.find("endsolid") != std::string_view::npos;
}

Status truncated_error(const std::string& source, uint32_t count, uint64_t size) {
  return error(ErrorCode::kInvalidData, source,
               "binary STL header declares " + std::to_string(count) + " triangles (" +
                   std::to_string(kHeaderBytes + uint64_t{count} * kRecordBytes) +
                   " bytes) but the file has " + std::to_string(size) + " bytes",
               at_byte(80));
}

Status parse_binary(const uint8_t* data, size_t size, const std::string& source,
                    const ReadOptions& options, Scene* scene) {
  ByteReader in(data, size);
  uint32_t count = 0;
  if (!in.skip(80) || !in.read_le(&count)) {
    return error(ErrorCode::kInvalidData, source,
                 "file too short for a binary STL header (84 bytes)", at_byte(size));
  }
  if (!in.fits(count, kRecordBytes)) return truncated_error(source, count, size);
  Mesh mesh;
  BinaryStlSink sink(&mesh, count, options.weld);
  OSTEON_RETURN_IF_ERROR(sink.add(in.current(), count, kHeaderBytes, source));
  mesh.stored_vertices = size_t{count} * 3;
  scene->parts.push_back(std::move(mesh));
  return {};
}

// ASCII: "solid name" { "facet normal n n n" "outer loop" "vertex x y z" x3 "endloop" "endfacet" }
// "endsolid name", possibly several solids in one file (each becomes a part named by its solid).
Status parse_ascii(const uint8_t* data, size_t size, const std::string& source,
                   const ReadOptions& options, Scene* scene) {
  TextReader in(data, size);
  auto expect = [&](std::string_view token, std::string_view want) -> Status {
    if (token == want) return {};
    return error(ErrorCode::kInvalidData, source,
                 "expected '" + std::string(want) + "' but found " + quote_token(token),
                 in.where());
  };
  size_t solids = 0;
  while (true) {
    std::string_view token = in.next_token();
    if (token.empty()) break;
    OSTEON_RETURN_IF_ERROR(expect(token, "solid"));
    Mesh mesh;
    in.skip_blanks();
    mesh.name = std::string(in.rest_of_line());
    if (mesh.name.size() > 200) mesh.name.resize(200);
    std::unique_ptr<ExactWelder> welder;
    if (options.weld) welder = std::make_unique<ExactWelder>(&mesh.positions, 1024);
    size_t vertices = 0;
    while (true) {
      token = in.next_token();
      if (token == "endsolid") {
        in.skip_line();
        break;
      }
      if (token.empty()) {
        return error(ErrorCode::kInvalidData, source, "file ends inside a solid (no 'endsolid')",
                     in.where());
      }
      OSTEON_RETURN_IF_ERROR(expect(token, "facet"));
      in.skip_line();  // "normal nx ny nz": recomputed from the vertices, never trusted
      OSTEON_RETURN_IF_ERROR(expect(in.next_token(), "outer"));
      OSTEON_RETURN_IF_ERROR(expect(in.next_token(), "loop"));
      for (int k = 0; k < 3; ++k) {
        OSTEON_RETURN_IF_ERROR(expect(in.next_token(), "vertex"));
        float xyz[3];
        for (float& c : xyz) {
          std::string_view number = in.next_token_on_line();
          if (!parse_float(number, &c)) {
            return error(ErrorCode::kInvalidData, source,
                         "expected a number but found " + quote_token(number), in.where());
          }
        }
        Vec3 v{xyz[0], xyz[1], xyz[2]};
        if (!is_finite(v)) return non_finite_error(source, vertices, in.where());
        ++vertices;
        if (welder) {
          mesh.indices.push_back(welder->insert(v));
        } else {
          mesh.indices.push_back(static_cast<uint32_t>(mesh.positions.size()));
          mesh.positions.push_back(v);
        }
      }
      OSTEON_RETURN_IF_ERROR(expect(in.next_token(), "endloop"));
      OSTEON_RETURN_IF_ERROR(expect(in.next_token(), "endfacet"));
    }
    mesh.stored_vertices = vertices;
    ++solids;
    if (!mesh.indices.empty()) scene->parts.push_back(std::move(mesh));
  }
  if (solids == 0)
    return error(ErrorCode::kInvalidData, source, "no 'solid' in the file", "line 1");
  return {};
}

}  // namespace

Status parse_stl(const uint8_t* data, size_t size, const std::string& source,
                 const ReadOptions& options, Scene* scene) {
  if (size >= kHeaderBytes) {
    uint32_t count = ByteReader::load<uint32_t>(data + 80, std::endian::little);
    bool size_matches = size == kHeaderBytes + uint64_t{count} * kRecordBytes;
    if (size_matches || !looks_ascii(data, size)) {
      return parse_binary(data, size, source, options, scene);
    }
  } else if (!looks_ascii(data, size)) {
    return error(ErrorCode::kInvalidData, source,
                 size == 0 ? "file is empty" : "file too short for a binary STL header (84 bytes)",
                 at_byte(size));
  }
  return parse_ascii(data, size, source, options, scene);
}

Status parse_stl_file(std::FILE* file, uint64_t size, const std::string& source,
                      const ReadOptions& options, Scene* scene) {
  uint8_t header[1024];
  size_t head = std::fread(header, 1, std::min<uint64_t>(size, sizeof(header)), file);
  if (head != std::min<uint64_t>(size, sizeof(header))) {
    return error(ErrorCode::kIoError, source, std::string("read failed: ") + std::strerror(errno));
  }
  bool binary = false;
  uint32_t count = 0;
  if (size >= kHeaderBytes) {
    count = ByteReader::load<uint32_t>(header + 80, std::endian::little);
    binary = size == kHeaderBytes + uint64_t{count} * kRecordBytes || !looks_ascii(header, head);
  }
  if (!binary) {
    // ASCII (or too short to tell): read it whole; ASCII STL is small next to its binary twin.
    std::vector<uint8_t> data(size);
    std::memcpy(data.data(), header, head);
    if (size > head && std::fread(data.data() + head, 1, size - head, file) != size - head) {
      return error(ErrorCode::kIoError, source,
                   std::string("read failed: ") + std::strerror(errno));
    }
    return parse_stl(data.data(), data.size(), source, options, scene);
  }
  if ((size - kHeaderBytes) / kRecordBytes < count) return truncated_error(source, count, size);

  // Binary: stream whole records through a fixed buffer, welding as they arrive.
  Mesh mesh;
  BinaryStlSink sink(&mesh, count, options.weld);
  constexpr size_t kChunkRecords = 20972;  // ~1 MiB
  std::vector<uint8_t> buffer(kChunkRecords * kRecordBytes);
  size_t carried = head - kHeaderBytes;  // record bytes already in `header`
  std::memcpy(buffer.data(), header + kHeaderBytes, carried);
  uint64_t done = 0;
  while (done < count) {
    size_t want = static_cast<size_t>(std::min<uint64_t>(count - done, kChunkRecords));
    size_t need = want * kRecordBytes;
    if (carried < need) {
      size_t got = std::fread(buffer.data() + carried, 1, need - carried, file);
      if (got != need - carried) {
        return error(ErrorCode::kIoError, source,
                     std::string("read failed: ") + std::strerror(errno),
                     at_byte(kHeaderBytes + done * kRecordBytes + carried + got));
      }
    }
    OSTEON_RETURN_IF_ERROR(
        sink.add(buffer.data(), want, kHeaderBytes + done * kRecordBytes, source));
    // Bytes beyond this chunk's records (only possible on the first pass) move to the front.
    size_t extra = carried > need ? carried - need : 0;
    std::memmove(buffer.data(), buffer.data() + need, extra);
    carried = extra;
    done += want;
  }
  mesh.stored_vertices = size_t{count} * 3;
  scene->parts.push_back(std::move(mesh));
  return {};
}

}  // namespace osteon::detail
