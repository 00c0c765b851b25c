// SPDX-License-Identifier: Apache-2.0
#include "package/publish.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "fixtures.hpp"
#include "osteon/io.hpp"
#include "osteon/pack.hpp"
#include "osteon/package.hpp"

// pack publishes a package folder whole (docs/DESIGN.md "Publishing a package"): the real binary,
// stopped by the OSTEON_PACK_PAUSE_AT test hook at each point of the pipeline and killed with
// SIGKILL there, leaves the old package as it was; two packs at once leave one of them.

extern char** environ;

namespace osteon {
namespace {
namespace pack_publish_test {

namespace fs = std::filesystem;
using test::read_bytes;
using test::run_cli;
using test::scratch_dir;

using Tree = std::map<std::string, std::vector<uint8_t>>;

/// Every regular file below `dir`, relative path -> bytes.
Tree tree(const std::string& dir) {
  Tree files;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_regular_file()) {
      files[fs::relative(it->path(), dir).string()] = read_bytes(it->path().string());
    }
  }
  return files;
}

/// The names beside `dir` that pack's folders use (".DIR.osteon-tmp-*", ".DIR.osteon-old-*").
std::vector<std::string> leftovers(const std::string& dir, const std::string& kind) {
  const fs::path target(dir);
  const std::string prefix =
      std::string(".") + target.filename().string() + ".osteon-" + kind + "-";
  std::vector<std::string> out;
  for (const auto& entry : fs::directory_iterator(target.parent_path())) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) == 0) out.push_back(entry.path().string());
  }
  return out;
}

/// `osteon ARGS...` started with extra environment variables ("NAME=value"), output discarded.
pid_t spawn_cli(const std::vector<std::string>& args, const std::vector<std::string>& env) {
  std::vector<std::string> argv_s = {OSTEON_CLI_PATH};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<std::string> env_s;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry = *e;
    if (entry.rfind("OSTEON_PACK_", 0) != 0) env_s.push_back(entry);
  }
  env_s.insert(env_s.end(), env.begin(), env.end());
  std::vector<char*> argv, envp;
  for (std::string& s : argv_s) argv.push_back(s.data());
  for (std::string& s : env_s) envp.push_back(s.data());
  argv.push_back(nullptr);
  envp.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::dup2(null, 2);
    ::execve(argv[0], argv.data(), envp.data());
    ::_exit(127);
  }
  return pid;
}

/// Waits until `pid` stops (true) or ends (false).
bool wait_stopped(pid_t pid) {
  int status = 0;
  if (::waitpid(pid, &status, WUNTRACED) != pid) return false;
  return WIFSTOPPED(status);
}

/// Waits until `pid` ends; its exit status, or -1 when a signal ended it.
int wait_exit(pid_t pid) {
  int status = 0;
  if (::waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// Two packs of the phantom that give different packages: A (the old one) and B.
struct Fixture {
  std::string input = test::write_phantom(1);
  std::string root = scratch_dir();
  std::string viewer = root + "/viewer";
  std::vector<std::string> a, b;  ///< arguments after "pack INPUT -o DIR"
  Tree tree_a, tree_b;

  Fixture() {
    fs::create_directories(viewer + "/assets");
    test::write_bytes(viewer + "/index.html", "<!doctype html><title>osteon</title>");
    test::write_bytes(viewer + "/assets/viewer.js", "console.log('osteon')");
    a = {"--bits", "12", "--no-viewer", "--threads", "2"};
    b = {"--max-triangles", "300", "--viewer", viewer, "--threads", "2"};
    EXPECT_EQ(run(a, root + "/ref_a"), 0);
    EXPECT_EQ(run(b, root + "/ref_b"), 0);
    tree_a = tree(root + "/ref_a");
    tree_b = tree(root + "/ref_b");
    EXPECT_GT(tree_a.size(), 2u);
    EXPECT_TRUE(tree_a != tree_b);
  }

  std::vector<std::string> args(const std::vector<std::string>& options,
                                const std::string& out) const {
    std::vector<std::string> all = {"pack", input, "-o", out};
    all.insert(all.end(), options.begin(), options.end());
    return all;
  }
  pid_t start(const std::vector<std::string>& options, const std::string& out,
              const std::vector<std::string>& env = {}) const {
    return spawn_cli(args(options, out), env);
  }
  int run(const std::vector<std::string>& options, const std::string& out,
          const std::vector<std::string>& env = {}) const {
    return wait_exit(start(options, out, env));
  }
};

/// The package at `dir` reads back (read_package and `osteon info`).
void expect_readable(const std::string& dir, const std::string& when) {
  Result<Scene> scene = read_package(dir);
  EXPECT_TRUE(scene.ok()) << when << ": " << scene.status().message();
  test::CliRun info = run_cli("info " + dir);
  EXPECT_EQ(info.status, 0) << when << ": " << info.err;
}

TEST(PackPublish, KillAtEveryStageLeavesTheOldPackageWhole) {
  Fixture f;
  const std::string dir = f.root + "/site";
  ASSERT_EQ(f.run(f.a, dir), 0);
  ASSERT_TRUE(tree(dir) == f.tree_a);
  for (const char* point :
       {"read", "clean", "repeats", "segment", "levels", "encode", "write", "publish"}) {
    const pid_t pid = f.start(f.b, dir, {std::string(detail::kPauseEnv) + "=" + point});
    ASSERT_TRUE(wait_stopped(pid)) << point << ": pack never reached the pause";
    ::kill(pid, SIGKILL);
    EXPECT_EQ(wait_exit(pid), -1);
    EXPECT_TRUE(tree(dir) == f.tree_a) << "killed at " << point << ": the old package changed";
    expect_readable(dir, point);
    // From the write stage on, the killed pack leaves its folder beside DIR; each pack removes
    // those of the dead ones first.
    const bool wrote = std::string(point) == "write" || std::string(point) == "publish";
    EXPECT_EQ(leftovers(dir, "tmp").size(), wrote ? 1u : 0u) << point;
  }
  ASSERT_EQ(f.run(f.b, dir), 0);
  EXPECT_TRUE(tree(dir) == f.tree_b) << "DIR is exactly the new package, no old chunks";
  EXPECT_TRUE(leftovers(dir, "tmp").empty()) << "the next pack removes dead packs' folders";
  EXPECT_TRUE(leftovers(dir, "old").empty());
  expect_readable(dir, "after");
}

// Without renameat2(RENAME_EXCHANGE) the old package is renamed aside before the new one comes
// in; a pack killed between the two leaves it there, and the next pack, even one that fails,
// puts it back first.
TEST(PackPublish, KillBetweenTheTwoRenamesIsRecovered) {
  Fixture f;
  const std::string dir = f.root + "/site";
  const std::string no_exchange = std::string(detail::kNoExchangeEnv) + "=1";
  ASSERT_EQ(f.run(f.a, dir, {no_exchange}), 0);
  ASSERT_TRUE(tree(dir) == f.tree_a);
  ASSERT_EQ(f.run(f.b, dir, {no_exchange}), 0) << "the fallback publishes too";
  ASSERT_TRUE(tree(dir) == f.tree_b);
  EXPECT_TRUE(leftovers(dir, "old").empty());

  const pid_t pid = f.start(f.a, dir, {no_exchange, std::string(detail::kPauseEnv) + "=swap"});
  ASSERT_TRUE(wait_stopped(pid));
  ::kill(pid, SIGKILL);
  wait_exit(pid);
  EXPECT_FALSE(fs::exists(dir)) << "the window: DIR is missing";
  const std::vector<std::string> old = leftovers(dir, "old");
  ASSERT_EQ(old.size(), 1u);
  EXPECT_TRUE(tree(old[0]) == f.tree_b) << "the old package waits beside DIR, whole";
  EXPECT_EQ(leftovers(dir, "tmp").size(), 1u) << "and the new one, complete";

  // A pack that fails on its input still puts the old package back before it fails.
  test::CliRun failed = run_cli("pack /nonexistent/femur.stl -o " + dir);
  EXPECT_NE(failed.status, 0);
  EXPECT_TRUE(tree(dir) == f.tree_b);
  EXPECT_TRUE(leftovers(dir, "old").empty());
  EXPECT_TRUE(leftovers(dir, "tmp").empty());
  expect_readable(dir, "recovered");
  ASSERT_EQ(f.run(f.a, dir), 0);
  EXPECT_TRUE(tree(dir) == f.tree_a);
}

TEST(PackPublish, ConcurrentPacksLeaveOneWholePackage) {
  Fixture f;
  const std::string dir = f.root + "/site";
  // A holds the lock, stopped just before its swap; B waits for it, then swaps last.
  const pid_t a = f.start(f.a, dir, {std::string(detail::kPauseEnv) + "=publish"});
  ASSERT_TRUE(wait_stopped(a));
  const pid_t b = f.start(f.b, dir);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  int status = 0;
  EXPECT_EQ(::waitpid(b, &status, WNOHANG), 0) << "B waits for A's lock";
  ::kill(a, SIGCONT);
  EXPECT_EQ(wait_exit(a), 0);
  EXPECT_EQ(wait_exit(b), 0);
  EXPECT_TRUE(tree(dir) == f.tree_b);
  // Unordered races: whichever swaps last wins, and DIR is always one of the two.
  for (int round = 0; round < 3; ++round) {
    const pid_t first = f.start(f.a, dir);
    const pid_t second = f.start(f.b, dir);
    EXPECT_EQ(wait_exit(first), 0);
    EXPECT_EQ(wait_exit(second), 0);
    const Tree now = tree(dir);
    EXPECT_TRUE(now == f.tree_a || now == f.tree_b) << "round " << round;
    expect_readable(dir, "race");
  }
  EXPECT_TRUE(leftovers(dir, "tmp").empty());
  EXPECT_TRUE(leftovers(dir, "old").empty());
}

TEST(PackPublish, OnlyAPackageOrAnEmptyFolderIsReplaced) {
  Fixture f;
  const std::string dir = f.root + "/notes";
  fs::create_directories(dir);
  test::write_bytes(dir + "/notes.txt", "mine");
  test::CliRun refused = run_cli("pack " + f.input + " -o " + dir + " --no-viewer");
  EXPECT_EQ(refused.status, 2);
  EXPECT_NE(refused.err.find("not an osteon package"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find(dir), std::string::npos) << refused.err;
  EXPECT_EQ(tree(dir).size(), 1u) << "the folder is left alone";
  EXPECT_TRUE(leftovers(dir, "tmp").empty());

  const std::string file = f.root + "/file";
  test::write_bytes(file, "x");
  test::CliRun not_folder = run_cli("pack " + f.input + " -o " + file + " --no-viewer");
  EXPECT_EQ(not_folder.status, 2);
  EXPECT_NE(not_folder.err.find("not a folder"), std::string::npos) << not_folder.err;

  const std::string empty = f.root + "/empty";
  fs::create_directories(empty);
  ASSERT_EQ(f.run(f.a, empty), 0);
  EXPECT_TRUE(tree(empty) == f.tree_a);

  // The library: the report names DIR's manifest, not the folder it was written in; a folder
  // whose parents are missing is created; a trailing separator names the same folder.
  PackOptions options;
  options.output = f.root + "/deep/er/site/";
  options.bits = 12;
  Result<PackReport> report = pack({f.input}, options);
  ASSERT_TRUE(report.ok()) << report.status().message();
  EXPECT_EQ(fs::path(report->manifest).lexically_normal(),
            fs::path(f.root + "/deep/er/site/manifest.json").lexically_normal());
  EXPECT_TRUE(tree(f.root + "/deep/er/site") == f.tree_a);
  EXPECT_TRUE(leftovers(f.root + "/deep/er/site", "tmp").empty());
}

}  // namespace pack_publish_test
}  // namespace
}  // namespace osteon
