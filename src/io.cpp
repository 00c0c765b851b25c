// SPDX-License-Identifier: Apache-2.0
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "core/byte_io.hpp"
#include "io_internal.hpp"
#include "osteon/io.hpp"

// The dispatcher: which reader a file goes to, how files are brought into memory (mapped, or for
// binary STL streamed), how parts are named, welded and given a unit, and how folders of bone
// files become one scene.

namespace osteon {

namespace fs = std::filesystem;

const char* format_name(Format format) {
  switch (format) {
    case Format::kStl:
      return "stl";
    case Format::kObj:
      return "obj";
    case Format::kPly:
      return "ply";
    case Format::kOff:
      return "off";
    case Format::kVtk:
      return "vtk";
    case Format::kGltf:
      return "gltf";
    case Format::kGlb:
      return "glb";
    case Format::kUnknown:
      break;
  }
  return "unknown";
}

Format format_from_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (ext == ".stl") return Format::kStl;
  if (ext == ".obj") return Format::kObj;
  if (ext == ".ply") return Format::kPly;
  if (ext == ".off") return Format::kOff;
  if (ext == ".vtk") return Format::kVtk;
  if (ext == ".gltf") return Format::kGltf;
  if (ext == ".glb") return Format::kGlb;
  return Format::kUnknown;
}

namespace detail {

Format sniff_format(const uint8_t* data, size_t size) {
  std::string_view head(reinterpret_cast<const char*>(data), std::min<size_t>(size, 256));
  size_t start = 0;
  while (start < head.size() && TextReader::is_space(head[start])) ++start;
  std::string_view text = head.substr(start);
  auto starts = [&](std::string_view s) { return text.substr(0, s.size()) == s; };
  if (head.substr(0, 4) == "glTF") return Format::kGlb;
  if (starts("ply")) return Format::kPly;
  if (starts("# vtk DataFile")) return Format::kVtk;
  if (starts("OFF") || starts("COFF") || starts("NOFF") || starts("CNOFF") || starts("STOFF")) {
    return Format::kOff;
  }
  if (starts("{")) return Format::kGltf;
  if (starts("solid")) return Format::kStl;
  if (size >= 84) {
    uint32_t count = ByteReader::load<uint32_t>(data + 80, std::endian::little);
    if (size == 84 + uint64_t{count} * 50) return Format::kStl;
  }
  if (starts("v ") || starts("#") || starts("o ") || starts("g ") || starts("mtllib")) {
    return Format::kObj;
  }
  return Format::kUnknown;
}

}  // namespace detail

namespace {

std::string stem_of(const std::string& source) {
  return fs::path(source).stem().string();
}

Status dispatch(Format format, const uint8_t* data, size_t size, const std::string& source,
                const std::string& base_dir, const ReadOptions& options, Scene* scene) {
  switch (format) {
    case Format::kStl:
      return detail::parse_stl(data, size, source, options, scene);
    case Format::kObj:
      return detail::parse_obj(data, size, source, options, scene);
    case Format::kPly:
      return detail::parse_ply(data, size, source, options, scene);
    case Format::kOff:
      return detail::parse_off(data, size, source, options, scene);
    case Format::kVtk:
      return detail::parse_vtk(data, size, source, options, scene);
    case Format::kGltf:
    case Format::kGlb:
      return detail::parse_gltf(data, size, source, base_dir, options, scene);
    case Format::kUnknown:
      break;
  }
  return error(ErrorCode::kUnsupported, source,
               "unknown mesh format (expected .stl, .obj, .ply, .off, .vtk, .gltf or .glb)");
}

// Names the parts one file gave (`name` is "stem" for one part, "stem/sub" for several), welds
// them (STL is welded by its reader) and records where they came from.
Status finish_file(Format format, const std::string& source, const std::string& name,
                   const ReadOptions& options, Scene* file_scene) {
  if (file_scene->parts.empty()) {
    return error(ErrorCode::kInvalidData, source, "the file holds no triangles");
  }
  bool several = file_scene->parts.size() > 1;
  for (size_t i = 0; i < file_scene->parts.size(); ++i) {
    Mesh& part = file_scene->parts[i];
    if (several) {
      part.name = name + "/" + (part.name.empty() ? std::to_string(i) : part.name);
    } else {
      part.name = name;
    }
    part.source = source;
    if (part.stored_vertices == 0) part.stored_vertices = part.positions.size();
    if (options.weld && format != Format::kStl) weld(part);
  }
  return {};
}

}  // namespace

void detail::assign_unit(const ReadOptions& options, Scene* scene) {
  Unit unit = options.unit;
  UnitSource unit_source = UnitSource::kUser;
  if (unit == Unit::kUnknown) {
    unit = guess_unit(*scene);
    unit_source = unit == Unit::kUnknown ? UnitSource::kUnknown : UnitSource::kGuessed;
  }
  for (Mesh& part : scene->parts) {
    part.unit = unit;
    part.unit_source = unit_source;
  }
}

namespace {

Format pick_format(const uint8_t* data, size_t size, const std::string& source, Format format) {
  if (format == Format::kUnknown) format = format_from_extension(source);
  if (format == Format::kUnknown) format = detail::sniff_format(data, size);
  return format;
}

// A read-only view of a whole file: memory-mapped (no copy, pages shared with the page cache).
class MappedFile {
 public:
  MappedFile() = default;
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  ~MappedFile() {
    if (data_ != nullptr) munmap(data_, size_);
  }
  Status map(int fd, size_t size, const std::string& source) {
    void* p = mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (p == MAP_FAILED) {
      return error(ErrorCode::kIoError, source, std::string("cannot map: ") + std::strerror(errno));
    }
    madvise(p, size, MADV_SEQUENTIAL);
    data_ = p;
    size_ = size;
    return {};
  }
  const uint8_t* data() const { return static_cast<const uint8_t*>(data_); }
  size_t size() const { return size_; }

 private:
  void* data_ = nullptr;
  size_t size_ = 0;
};

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

// Opens a regular file of at most `max_bytes` for reading and gives its size: the checks every
// whole-file read makes before it allocates.
Status open_regular_file(const std::string& path, uint64_t max_bytes, FilePtr* file,
                         uint64_t* size) {
  file->reset(std::fopen(path.c_str(), "rb"));
  if (*file == nullptr) {
    return error(ErrorCode::kIoError, path, std::string("cannot open: ") + std::strerror(errno));
  }
  struct stat st {};
  if (fstat(fileno(file->get()), &st) != 0) {
    return error(ErrorCode::kIoError, path, std::string("cannot stat: ") + std::strerror(errno));
  }
  if (S_ISDIR(st.st_mode)) return error(ErrorCode::kIoError, path, "is a folder, not a file");
  if (!S_ISREG(st.st_mode)) return error(ErrorCode::kIoError, path, "is not a regular file");
  *size = static_cast<uint64_t>(st.st_size);
  if (*size > max_bytes) {
    return error(ErrorCode::kInvalidArgument, path,
                 "file is " + std::to_string(*size) + " bytes, over the limit of " +
                     std::to_string(max_bytes));
  }
  return {};
}

// Reads one file into `scene` (appending), naming its parts from `name`.
Status read_one_file(const std::string& path, const std::string& name, const ReadOptions& options,
                     Scene* scene) {
  FilePtr owned;
  uint64_t size = 0;
  OSTEON_RETURN_IF_ERROR(open_regular_file(path, options.max_file_bytes, &owned, &size));
  std::FILE* file = owned.get();
  if (size == 0) return error(ErrorCode::kInvalidData, path, "file is empty", "byte 0");

  Scene file_scene;
  Format format = format_from_extension(path);
  if (format == Format::kStl) {
    OSTEON_RETURN_IF_ERROR(detail::parse_stl_file(file, size, path, options, &file_scene));
  } else {
    MappedFile mapped;
    OSTEON_RETURN_IF_ERROR(mapped.map(fileno(file), static_cast<size_t>(size), path));
    format = pick_format(mapped.data(), mapped.size(), path, format);
    fs::path parent = fs::path(path).parent_path();
    const std::string base_dir = parent.empty() ? std::string(".") : parent.string();
    OSTEON_RETURN_IF_ERROR(
        dispatch(format, mapped.data(), mapped.size(), path, base_dir, options, &file_scene));
  }
  OSTEON_RETURN_IF_ERROR(finish_file(format, path, name, options, &file_scene));
  for (Mesh& part : file_scene.parts) scene->parts.push_back(std::move(part));
  return {};
}

}  // namespace

Result<std::vector<uint8_t>> read_file(const std::string& path, uint64_t max_bytes) {
  FilePtr file;
  uint64_t size = 0;
  OSTEON_RETURN_IF_ERROR(open_regular_file(path, max_bytes, &file, &size));
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  if (std::fread(bytes.data(), 1, bytes.size(), file.get()) != bytes.size()) {
    return error(ErrorCode::kIoError, path, "cannot read");
  }
  return bytes;
}

Result<Scene> read_memory(const uint8_t* data, size_t size, const std::string& source,
                          Format format, const ReadOptions& options) {
  if (size == 0) return error(ErrorCode::kInvalidData, source, "file is empty", "byte 0");
  format = pick_format(data, size, source, format);
  Scene scene;
  OSTEON_RETURN_IF_ERROR(dispatch(format, data, size, source, {}, options, &scene));
  OSTEON_RETURN_IF_ERROR(finish_file(format, source, stem_of(source), options, &scene));
  detail::assign_unit(options, &scene);
  return scene;
}

Result<Scene> read_meshes(const std::string& path, const ReadOptions& options) {
  std::error_code ec;
  fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) {
    return error(ErrorCode::kIoError, path, "no such file or folder");
  }
  Scene scene;
  if (!fs::is_directory(status)) {
    OSTEON_RETURN_IF_ERROR(read_one_file(path, stem_of(path), options, &scene));
    detail::assign_unit(options, &scene);
    return scene;
  }
  // A folder: every mesh file below it, in sorted order, named by its relative path.
  std::vector<fs::path> files;
  fs::recursive_directory_iterator it(path, fs::directory_options::skip_permission_denied, ec);
  if (ec) return error(ErrorCode::kIoError, path, "cannot list the folder: " + ec.message());
  uint64_t total = 0;
  for (; it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (ec) return error(ErrorCode::kIoError, path, "cannot list the folder: " + ec.message());
    const fs::directory_entry& entry = *it;
    std::string file_name = entry.path().filename().string();
    if (file_name.empty() || file_name[0] == '.') continue;
    if (!entry.is_regular_file(ec)) continue;
    if (format_from_extension(file_name) == Format::kUnknown) continue;
    total += entry.file_size(ec);
    if (total > options.max_file_bytes) {
      return error(ErrorCode::kInvalidArgument, path,
                   "the folder's mesh files add up to more than the limit of " +
                       std::to_string(options.max_file_bytes) + " bytes");
    }
    files.push_back(entry.path());
  }
  if (files.empty()) {
    return error(ErrorCode::kIoError, path,
                 "the folder holds no mesh file (.stl, .obj, .ply, .off, .vtk, .gltf, .glb)");
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    fs::path relative = file.lexically_relative(path);
    std::string name = (relative.parent_path() / relative.stem()).generic_string();
    OSTEON_RETURN_IF_ERROR(read_one_file(file.string(), name, options, &scene));
  }
  detail::assign_unit(options, &scene);
  return scene;
}

}  // namespace osteon
