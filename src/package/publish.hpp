// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "osteon/pack.hpp"
#include "osteon/status.hpp"

// How pack() puts a package folder in place whole (docs/DESIGN.md "Publishing a package"): the
// files go into a fresh folder beside DIR, which then takes DIR's place by one rename (Linux:
// renameat2(RENAME_EXCHANGE)), under an exclusive lock on a file beside DIR. The names beside DIR
// are docs/FORMAT.md's "Beside the package folder".

namespace osteon::detail {

/// Test hook: when set to a stage name (stage_name()) or to "publish" or "swap", pack() stops
/// itself with SIGSTOP on reaching that point, so a test can kill it there. "publish": the new
/// folder is complete and the lock is held, just before the swap; "swap": between the two
/// renames of the fallback, where DIR is missing (see kNoExchangeEnv).
inline constexpr const char* kPauseEnv = "OSTEON_PACK_PAUSE_AT";
/// Test hook: when set (non-empty), publishing uses the two-rename fallback even where
/// renameat2(RENAME_EXCHANGE) works.
inline constexpr const char* kNoExchangeEnv = "OSTEON_PACK_NO_EXCHANGE";

/// Stops the process (SIGSTOP) when $OSTEON_PACK_PAUSE_AT is `point`, after saying so on stderr.
void pause_if_asked(const char* point);

/// `progress`, wrapped so that the first report of the stage named by $OSTEON_PACK_PAUSE_AT
/// calls pause_if_asked(); `progress` itself when the variable is unset.
std::function<void(PackStage, uint64_t, uint64_t)> with_pause_hook(
    std::function<void(PackStage, uint64_t, uint64_t)> progress);

/// Checks, under the lock, that `dir` can take a package: absent, an empty folder or a package
/// (a folder with manifest.json); first cleans what crashed packs left beside it (their folders,
/// and, when `dir` is missing because a pack died between its two renames, the old package is
/// renamed back). Errors: kInvalidArgument when `dir` is a file or a folder that is neither
/// empty nor a package; kIoError when the lock or a clean-up fails.
Status prepare_package_folder(const std::string& dir);

/// The fresh folder beside a package folder that pack writes into; removed with everything in
/// it when destroyed unless publish_package_folder() put it in place.
struct StagedPackage {
  std::string dir;     ///< the package folder, as given
  std::string target;  ///< the package folder, absolute, symbolic links resolved
  std::string folder;  ///< the fresh folder beside `target`; empty once published

  StagedPackage() = default;
  StagedPackage(StagedPackage&& other) noexcept;
  StagedPackage& operator=(StagedPackage&&) = delete;
  StagedPackage(const StagedPackage&) = delete;
  ~StagedPackage();
};

/// Creates the fresh folder beside `dir` (and `dir`'s parent folders when missing). Errors:
/// kInvalidArgument for the file-system root; kIoError when a folder cannot be created.
Result<StagedPackage> stage_package_folder(const std::string& dir);

/// Puts the completed `staged` folder in the package folder's place: under the lock, cleans
/// leftovers and checks the target again (prepare_package_folder), then swaps (one atomic
/// exchange, or the target renamed aside, the new folder renamed in, and on failure the old one
/// renamed back), then removes the old package (what a failed removal leaves, the next pack
/// removes). Errors: prepare_package_folder's; kIoError when a rename fails (the old package is
/// then still in place).
Status publish_package_folder(StagedPackage* staged);

}  // namespace osteon::detail
