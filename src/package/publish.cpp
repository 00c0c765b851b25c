// SPDX-License-Identifier: Apache-2.0
#include "package/publish.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

// Based on: the write-aside-then-rename habit of maildir and of package managers (dpkg's
// .dpkg-new files), with Linux's renameat2(RENAME_EXCHANGE) (since 3.15) swapping two folders in
// one step where the file system supports it.
//
// Beside DIR, in DIR's parent (docs/FORMAT.md "Beside the package folder"):
//
//   .DIR.osteon-lock             held with flock(LOCK_EX) while leftovers are cleaned and the
//                                folders swapped; never removed
//   .DIR.osteon-tmp-<pid>-<hex>  the new package being written by process <pid>
//   .DIR.osteon-old-<pid>-<hex>  the old package, renamed aside by the two-rename fallback
//
//   exchange:   tmp <-> DIR                     (DIR is never missing), then remove tmp (the old)
//   fallback:   DIR -> old, tmp -> DIR          (DIR is missing between the two), then remove old

namespace osteon::detail {

namespace {

namespace fs = std::filesystem;

std::string errno_message(int code) {
  return std::strerror(code);
}

/// The absolute path of `dir` with symbolic links resolved (so a link to a package folder gets
/// its target replaced, not the link), no trailing separator.
Result<fs::path> resolve_target(const std::string& dir) {
  std::error_code ec;
  fs::path target = fs::weakly_canonical(fs::absolute(dir, ec), ec);
  if (ec) return error(ErrorCode::kIoError, dir, "cannot resolve the folder: " + ec.message());
  if (!target.has_filename()) target = target.parent_path();
  if (!target.has_filename() || target == target.root_path() || target.filename() == "." ||
      target.filename() == "..") {
    return error(ErrorCode::kInvalidArgument, dir, "cannot pack into the file-system root");
  }
  return target;
}

/// ".DIR.osteon-": what every name beside DIR starts with.
std::string prefix_of(const fs::path& target) {
  std::string prefix = ".";
  prefix += target.filename().string();
  prefix += ".osteon-";
  return prefix;
}

/// A name beside DIR for a folder of this process: ".DIR.osteon-<kind>-<pid>-<hex>".
std::string own_name(const fs::path& target, const char* kind) {
  static std::random_device device;
  char hex[17];
  std::snprintf(hex, sizeof(hex), "%08x%08x", device(), device());
  return prefix_of(target) + kind + "-" + std::to_string(::getpid()) + "-" + hex;
}

/// The exclusive lock on ".DIR.osteon-lock", held while the object lives.
class FolderLock {
 public:
  FolderLock() = default;
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  ~FolderLock() {
    if (fd_ >= 0) ::close(fd_);  // closing the descriptor releases the lock
  }

  /// Waits for the lock: it is held only for the clean-up and the swap, milliseconds.
  Status lock(const fs::path& target, const std::string& dir) {
    const std::string path = (target.parent_path() / (prefix_of(target) + "lock")).string();
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) {
      return error(ErrorCode::kIoError, path,
                   "cannot open the lock file of " + dir + ": " + errno_message(errno));
    }
    while (::flock(fd_, LOCK_EX) != 0) {
      if (errno != EINTR) {
        return error(ErrorCode::kIoError, path,
                     "cannot lock the package folder " + dir + ": " + errno_message(errno));
      }
    }
    return {};
  }

 private:
  int fd_ = -1;
};

/// A folder beside DIR left by a pack: its kind ("tmp" or "old") and process id.
struct Leftover {
  fs::path path;
  std::string kind;
  long pid = 0;
};

/// The "tmp" and "old" folders beside `target` whose process is gone (not this one: another
/// thread of it may be packing into the same folder).
std::vector<Leftover> dead_leftovers(const fs::path& target) {
  std::vector<Leftover> out;
  const std::string prefix = prefix_of(target);
  std::error_code ec;
  for (fs::directory_iterator it(target.parent_path(), ec), end; !ec && it != end;
       it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const std::string rest = name.substr(prefix.size());  // "tmp-<pid>-<hex>"
    Leftover left{it->path(), rest.substr(0, 3), 0};
    if ((left.kind != "tmp" && left.kind != "old") || rest.size() < 5 || rest[3] != '-') continue;
    char* end_of_pid = nullptr;
    left.pid = std::strtol(rest.c_str() + 4, &end_of_pid, 10);
    if (left.pid <= 0 || *end_of_pid != '-') continue;
    if (left.pid == static_cast<long>(::getpid())) continue;
    const bool alive = ::kill(static_cast<pid_t>(left.pid), 0) == 0 || errno == EPERM;
    if (!alive) out.push_back(std::move(left));
  }
  return out;
}

/// Removes a package folder that is no longer wanted: manifest.json first, so that a removal cut
/// short never leaves something that looks like a package.
Status remove_folder(const fs::path& folder) {
  std::error_code ec;
  fs::remove(folder / "manifest.json", ec);
  fs::remove_all(folder, ec);
  if (ec) return error(ErrorCode::kIoError, folder.string(), "cannot remove: " + ec.message());
  return {};
}

/// Under the lock: a missing target whose old package a dead pack had renamed aside gets it
/// back; every other leftover of a dead pack goes.
Status clean_leftovers(const fs::path& target) {
  std::error_code ec;
  std::vector<Leftover> leftovers = dead_leftovers(target);
  if (!fs::exists(fs::symlink_status(target, ec))) {
    for (auto it = leftovers.begin(); it != leftovers.end(); ++it) {
      if (it->kind != "old" || !fs::is_regular_file(it->path / "manifest.json", ec)) continue;
      fs::rename(it->path, target, ec);
      if (ec) {
        return error(ErrorCode::kIoError, it->path.string(),
                     "cannot put the old package back in place: " + ec.message());
      }
      leftovers.erase(it);
      break;
    }
  }
  for (const Leftover& left : leftovers) OSTEON_RETURN_IF_ERROR(remove_folder(left.path));
  return {};
}

/// The target may be replaced: absent, an empty folder, or a package.
Status check_target(const fs::path& target, const std::string& dir) {
  std::error_code ec;
  const fs::file_status status = fs::status(target, ec);
  if (!fs::exists(status)) return {};
  if (!fs::is_directory(status)) {
    return error(ErrorCode::kInvalidArgument, dir,
                 "exists and is not a folder; pack writes a package folder");
  }
  if (fs::is_regular_file(target / "manifest.json", ec)) return {};
  if (fs::is_empty(target, ec) && !ec) return {};
  return error(ErrorCode::kInvalidArgument, dir,
               "the folder exists and is not an osteon package (no manifest.json); pack replaces "
               "the whole folder, so it writes only into a package, an empty folder or a new one");
}

/// fsync of a folder, so that the renames in it survive a power cut.
void sync_folder(const fs::path& folder) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

/// fsync of `root` and every folder below it: the renames of write_file_atomic inside them.
void sync_tree(const fs::path& root) {
  std::error_code ec;
  for (fs::recursive_directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_directory(ec)) sync_folder(it->path());
  }
  sync_folder(root);
}

bool env_set(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != 0;
}

/// renameat2(RENAME_EXCHANGE): 0 on success, else the errno; ENOSYS where there is none.
int exchange(const fs::path& a, const fs::path& b) {
#if defined(__linux__) && defined(RENAME_EXCHANGE)
  if (::renameat2(AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), RENAME_EXCHANGE) == 0) return 0;
  return errno;
#else
  (void)a;
  (void)b;
  return ENOSYS;
#endif
}

}  // namespace

void pause_if_asked(const char* point) {
  const char* at = std::getenv(kPauseEnv);
  if (at == nullptr || std::strcmp(at, point) != 0) return;
  std::fprintf(stderr, "osteon: test hook: paused at %s (%s)\n", point, kPauseEnv);
  std::fflush(stderr);
  ::raise(SIGSTOP);
}

std::function<void(PackStage, uint64_t, uint64_t)> with_pause_hook(
    std::function<void(PackStage, uint64_t, uint64_t)> progress) {
  if (!env_set(kPauseEnv)) return progress;
  return [progress = std::move(progress), paused = false](PackStage stage, uint64_t done,
                                                          uint64_t total) mutable {
    if (!paused) {
      const char* at = std::getenv(kPauseEnv);
      if (at != nullptr && std::strcmp(at, stage_name(stage)) == 0) {
        paused = true;
        pause_if_asked(stage_name(stage));
      }
    }
    if (progress) progress(stage, done, total);
  };
}

Status prepare_package_folder(const std::string& dir) {
  OSTEON_ASSIGN_OR_RETURN(fs::path target, resolve_target(dir));
  std::error_code ec;
  if (!fs::is_directory(target.parent_path(), ec)) return {};  // nothing beside it yet
  FolderLock lock;
  OSTEON_RETURN_IF_ERROR(lock.lock(target, dir));
  OSTEON_RETURN_IF_ERROR(clean_leftovers(target));
  return check_target(target, dir);
}

StagedPackage::StagedPackage(StagedPackage&& other) noexcept
    : dir(std::move(other.dir)),
      target(std::move(other.target)),
      folder(std::exchange(other.folder, std::string())) {}

StagedPackage::~StagedPackage() {
  if (!folder.empty()) (void)remove_folder(folder);
}

Result<StagedPackage> stage_package_folder(const std::string& dir) {
  OSTEON_ASSIGN_OR_RETURN(fs::path target, resolve_target(dir));
  std::error_code ec;
  fs::create_directories(target.parent_path(), ec);
  if (ec) {
    return error(ErrorCode::kIoError, target.parent_path().string(),
                 "cannot create the folder: " + ec.message());
  }
  StagedPackage staged;
  staged.dir = dir;
  staged.target = target.string();
  for (int attempt = 0; attempt < 16 && staged.folder.empty(); ++attempt) {
    const fs::path folder = target.parent_path() / own_name(target, "tmp");
    if (fs::create_directory(folder, ec)) staged.folder = folder.string();
    if (ec) {
      return error(ErrorCode::kIoError, folder.string(),
                   "cannot create the folder the package is written into: " + ec.message());
    }
  }
  if (staged.folder.empty()) {
    return error(ErrorCode::kIoError, dir, "cannot find a free temporary name beside it");
  }
  return staged;
}

Status publish_package_folder(StagedPackage* staged) {
  const fs::path target(staged->target);
  const fs::path folder(staged->folder);
  const fs::path parent = target.parent_path();
  sync_tree(folder);
  fs::path old;  // where the old package went, to be removed once the lock is released
  {
    FolderLock lock;
    OSTEON_RETURN_IF_ERROR(lock.lock(target, staged->dir));
    OSTEON_RETURN_IF_ERROR(clean_leftovers(target));
    OSTEON_RETURN_IF_ERROR(check_target(target, staged->dir));
    pause_if_asked("publish");
    std::error_code ec;
    if (!fs::exists(fs::symlink_status(target, ec))) {
      fs::rename(folder, target, ec);
      if (ec) {
        return error(ErrorCode::kIoError, staged->dir,
                     "cannot rename the new package into place: " + ec.message());
      }
    } else {
      const int code = env_set(kNoExchangeEnv) ? ENOSYS : exchange(folder, target);
      if (code == 0) {
        old = folder;  // the exchange left the old package under the new one's name
      } else if (code == EINVAL || code == ENOSYS || code == ENOTSUP || code == EOPNOTSUPP) {
        // No exchange on this file system: rename the old package aside, then the new one in.
        // DIR is missing between the two renames; a crash there leaves the old package under
        // its "old" name, which the next pack puts back (clean_leftovers).
        old = parent / own_name(target, "old");
        fs::rename(target, old, ec);
        if (ec) {
          return error(ErrorCode::kIoError, staged->dir,
                       "cannot rename the old package aside: " + ec.message());
        }
        pause_if_asked("swap");
        fs::rename(folder, target, ec);
        if (ec) {
          const std::string why = ec.message();
          fs::rename(old, target, ec);
          return error(ErrorCode::kIoError, staged->dir,
                       "cannot rename the new package into place: " + why +
                           (ec ? "; the old package is left at " + old.string() : ""));
        }
      } else {
        return error(ErrorCode::kIoError, staged->dir,
                     "cannot swap the new package into place: " + errno_message(code));
      }
    }
    staged->folder.clear();
    sync_folder(parent);
  }
  // The new package is in place: what a failed removal leaves, the next pack removes.
  if (!old.empty()) (void)remove_folder(old);
  return {};
}

}  // namespace osteon::detail
