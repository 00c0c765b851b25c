// SPDX-License-Identifier: Apache-2.0
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "osteon/io.hpp"

// Based on: the write-temporary-then-rename idiom (POSIX rename(2) replaces the target atomically;
// the same trick as git's lockfiles and LMDB/SQLite journals): a reader of `path` sees the old file
// or the whole new one, never a half-written one. Formats: the binary STL layout (80-byte header,
// uint32 count, 50 bytes a facet), PLY 1.0 (Greg Turk's spec, binary_little_endian), Wavefront OBJ.
// Floats are printed by std::to_chars in the shortest form that reads back to the same float.

namespace osteon {
namespace {

namespace fs = std::filesystem;

std::string errno_text(int code) {
  return std::generic_category().message(code);
}

/// A file written through a temporary beside its target and renamed over it on commit(). Writes
/// are buffered; the first failure is remembered and later writes are dropped, so callers write
/// everything and check once. Destroying an uncommitted file removes the temporary.
class AtomicFile {
 public:
  static constexpr size_t kBufferBytes = size_t{1} << 20;

  explicit AtomicFile(std::string path) : path_(std::move(path)) {}
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile() { discard(); }

  Status open() {
    static std::atomic<uint64_t> counter{0};
    // "x" (C11 exclusive mode): never open a file someone else made under the same name.
    for (int attempt = 0; attempt < 16 && !file_; ++attempt) {
      temp_ = path_ + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
      file_ = std::fopen(temp_.c_str(), "wbx");
      if (!file_ && errno != EEXIST) break;
    }
    if (!file_) {
      int code = errno;
      temp_.clear();
      return error(ErrorCode::kIoError, path_,
                   "cannot create a temporary file beside it: " + errno_text(code));
    }
    std::setvbuf(file_, nullptr, _IONBF, 0);  // our buffer is the only one
    buffer_.resize(kBufferBytes);
    return Status();
  }

  /// Room for at least `n` more bytes in the buffer (n <= kBufferBytes); nullptr after a failure.
  uint8_t* reserve(size_t n) {
    if (used_ + n > buffer_.size()) flush();
    return failed() ? nullptr : buffer_.data() + used_;
  }
  void advance(size_t n) { used_ += n; }

  void write(const void* data, size_t size) {
    const auto* bytes = static_cast<const uint8_t*>(data);
    while (size > 0 && !failed()) {
      if (used_ == buffer_.size()) flush();
      size_t n = std::min(size, buffer_.size() - used_);
      std::memcpy(buffer_.data() + used_, bytes, n);
      used_ += n;
      bytes += n;
      size -= n;
    }
  }
  void write(std::string_view text) { write(text.data(), text.size()); }

  /// Flushes, syncs, closes and renames the temporary over the target.
  Status commit() {
    flush();
    if (!failed() && std::fflush(file_) != 0) fail(errno);
    if (!failed() && ::fsync(::fileno(file_)) != 0 && errno != EINVAL) fail(errno);
    if (std::fclose(file_) != 0 && !failed()) fail(errno);
    file_ = nullptr;
    if (failed()) {
      discard();
      return error(ErrorCode::kIoError, path_, "cannot write: " + errno_text(error_));
    }
    std::error_code ec;
    fs::rename(temp_, path_, ec);
    if (ec) {
      discard();
      return error(ErrorCode::kIoError, path_, "cannot replace it: " + ec.message());
    }
    temp_.clear();
    return Status();
  }

 private:
  bool failed() const { return error_ != 0; }
  void fail(int code) {
    if (error_ == 0) error_ = code != 0 ? code : EIO;
  }
  void flush() {
    if (!failed() && used_ > 0 && std::fwrite(buffer_.data(), 1, used_, file_) != used_)
      fail(errno);
    used_ = 0;
  }
  void discard() {
    if (file_) std::fclose(file_);
    file_ = nullptr;
    if (!temp_.empty()) std::remove(temp_.c_str());
    temp_.clear();
  }

  std::string path_;
  std::string temp_;
  std::FILE* file_ = nullptr;
  std::vector<uint8_t> buffer_;
  size_t used_ = 0;
  int error_ = 0;
};

// ---- little-endian stores ------------------------------------------------------------------

void store_u32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
void store_f32(uint8_t* p, float v) {
  store_u32(p, std::bit_cast<uint32_t>(v));
}
void store_vec3(uint8_t* p, const Vec3& v) {
  store_f32(p, v.x);
  store_f32(p + 4, v.y);
  store_f32(p + 8, v.z);
}

/// The mesh's name on one line (PLY comments and OBJ object names end at a line break).
std::string one_line(const std::string& text) {
  std::string out = text;
  for (char& c : out)
    if (c == '\n' || c == '\r' || c == '\0') c = ' ';
  return out;
}

// ---- formats -------------------------------------------------------------------------------

/// The unit normal of a triangle, computed in double; zero for a zero-area triangle.
Vec3 facet_normal(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3d n = triangle_cross(a, b, c);
  const double l = length(n);
  if (!(l > 0) || !std::isfinite(l)) return {};
  return {float(n.x / l), float(n.y / l), float(n.z / l)};
}

void write_stl(AtomicFile& out, const Mesh& mesh) {
  // The header must not begin with "solid", or readers take the file for ASCII STL.
  uint8_t header[84] = {};
  std::string title = "osteon binary STL";
  if (!mesh.name.empty()) title += ": " + one_line(mesh.name);
  std::memcpy(header, title.data(), std::min<size_t>(title.size(), 80));
  store_u32(header + 80, static_cast<uint32_t>(mesh.triangle_count()));
  out.write(header, sizeof(header));
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3& a = mesh.positions[mesh.indices[3 * t]];
    const Vec3& b = mesh.positions[mesh.indices[3 * t + 1]];
    const Vec3& c = mesh.positions[mesh.indices[3 * t + 2]];
    uint8_t* p = out.reserve(50);
    if (!p) return;
    store_vec3(p, facet_normal(a, b, c));
    store_vec3(p + 12, a);
    store_vec3(p + 24, b);
    store_vec3(p + 36, c);
    p[48] = p[49] = 0;  // attribute byte count
    out.advance(50);
  }
}

void write_ply(AtomicFile& out, const Mesh& mesh) {
  bool has_normals = !mesh.normals.empty();
  // PLY's "int" is signed: beyond 2^31 - 1 vertices the indices need "uint".
  bool wide = mesh.vertex_count() > size_t(std::numeric_limits<int32_t>::max());
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment written by osteon\n";
  if (!mesh.name.empty()) header += "comment name " + one_line(mesh.name) + "\n";
  header += "element vertex " + std::to_string(mesh.vertex_count()) + "\n";
  header += "property float x\nproperty float y\nproperty float z\n";
  if (has_normals) header += "property float nx\nproperty float ny\nproperty float nz\n";
  header += "element face " + std::to_string(mesh.triangle_count()) + "\n";
  header += wide ? "property list uchar uint vertex_indices\n"
                 : "property list uchar int vertex_indices\n";
  header += "end_header\n";
  out.write(header);
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    uint8_t* p = out.reserve(24);
    if (!p) return;
    store_vec3(p, mesh.positions[v]);
    if (has_normals) store_vec3(p + 12, mesh.normals[v]);
    out.advance(has_normals ? 24 : 12);
  }
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    uint8_t* p = out.reserve(13);
    if (!p) return;
    p[0] = 3;
    for (int k = 0; k < 3; ++k) store_u32(p + 1 + 4 * k, mesh.indices[3 * t + k]);
    out.advance(13);
  }
}

/// Appends "<prefix> x y z\n", each float in its shortest round-trip form.
size_t format_vec3(char* out, const char* prefix, const Vec3& v) {
  char* p = out;
  while (*prefix) *p++ = *prefix++;
  for (float f : {v.x, v.y, v.z}) {
    *p++ = ' ';
    p = std::to_chars(p, p + 32, f).ptr;
  }
  *p++ = '\n';
  return size_t(p - out);
}

void write_obj(AtomicFile& out, const Mesh& mesh) {
  bool has_normals = !mesh.normals.empty();
  out.write("# written by osteon\n");
  out.write("o " + (mesh.name.empty() ? std::string("mesh") : one_line(mesh.name)) + "\n");
  // A line is at most 2 + 3 * (1 + 15) + 1 bytes for "vn" (a shortest float form is at most a sign,
  // 9 digits, a point and a 4-character exponent) and 1 + 3 * (1 + 10 + 2 + 10) + 1 for a face.
  constexpr size_t kMaxLine = 128;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    char* p = reinterpret_cast<char*>(out.reserve(kMaxLine));
    if (!p) return;
    out.advance(format_vec3(p, "v", mesh.positions[v]));
  }
  for (size_t v = 0; v < mesh.normals.size(); ++v) {
    char* p = reinterpret_cast<char*>(out.reserve(kMaxLine));
    if (!p) return;
    out.advance(format_vec3(p, "vn", mesh.normals[v]));
  }
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    char* start = reinterpret_cast<char*>(out.reserve(kMaxLine));
    if (!start) return;
    char* p = start;
    *p++ = 'f';
    for (int k = 0; k < 3; ++k) {
      uint64_t index = uint64_t{mesh.indices[3 * t + k]} + 1;  // OBJ counts from 1
      *p++ = ' ';
      p = std::to_chars(p, p + 20, index).ptr;
      if (has_normals) {
        *p++ = '/';
        *p++ = '/';
        p = std::to_chars(p, p + 20, index).ptr;
      }
    }
    *p++ = '\n';
    out.advance(size_t(p - start));
  }
}

/// What a writer needs of a mesh; a violation is the caller's bug, reported as kInvalidArgument
/// rather than written into a file nobody can read back.
Status check_mesh(const std::string& path, const Mesh& mesh, Format format) {
  auto bad = [&](const std::string& what) {
    return error(ErrorCode::kInvalidArgument, path, what);
  };
  if (mesh.indices.size() % 3 != 0)
    return bad(std::to_string(mesh.indices.size()) + " indices is not a whole number of triangles");
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
    return bad(std::to_string(mesh.normals.size()) + " normals for " +
               std::to_string(mesh.positions.size()) + " vertices");
  for (size_t i = 0; i < mesh.indices.size(); ++i) {
    if (mesh.indices[i] >= mesh.positions.size())
      return bad("triangle " + std::to_string(i / 3) + " refers to vertex " +
                 std::to_string(mesh.indices[i]) + " of " + std::to_string(mesh.positions.size()));
  }
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3& p = mesh.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      return bad("vertex " + std::to_string(v) + " has a NaN or infinite coordinate");
  }
  for (size_t v = 0; v < mesh.normals.size(); ++v) {
    const Vec3& n = mesh.normals[v];
    if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z))
      return bad("normal " + std::to_string(v) + " has a NaN or infinite coordinate");
  }
  if (format == Format::kStl && mesh.triangle_count() > std::numeric_limits<uint32_t>::max())
    return bad(std::to_string(mesh.triangle_count()) + " triangles do not fit a binary STL");
  return Status();
}

}  // namespace

Status write_file_atomic(const std::string& path, const void* data, size_t size) {
  AtomicFile out(path);
  OSTEON_RETURN_IF_ERROR(out.open());
  out.write(data, size);
  return out.commit();
}

Status write_mesh(const std::string& path, const Mesh& mesh) {
  Format format = format_from_extension(path);
  if (format != Format::kStl && format != Format::kPly && format != Format::kObj) {
    return error(ErrorCode::kInvalidArgument, path,
                 "osteon writes .stl, .ply and .obj, not this extension");
  }
  OSTEON_RETURN_IF_ERROR(check_mesh(path, mesh, format));
  AtomicFile out(path);
  OSTEON_RETURN_IF_ERROR(out.open());
  switch (format) {
    case Format::kStl:
      write_stl(out, mesh);
      break;
    case Format::kPly:
      write_ply(out, mesh);
      break;
    default:
      write_obj(out, mesh);
      break;
  }
  return out.commit();
}

}  // namespace osteon
