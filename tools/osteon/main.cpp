// SPDX-License-Identifier: Apache-2.0
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <functional>
#include <iostream>

#include "cli.hpp"

// osteon: one binary, one subcommand per pipeline stage (tools/osteon/cmd_<verb>.cpp).

namespace osteon::cli {

int fail(const Status& status) {
  return fail(status.message());
}

int fail(const std::string& message) {
  std::fprintf(stderr, "osteon: error: %s\n", message.c_str());
  return kExitError;
}

bool stderr_is_tty() {
  return isatty(STDERR_FILENO) != 0;
}

}  // namespace osteon::cli

int main(int argc, char** argv) {
  using namespace osteon::cli;
  CLI::App app{"osteon: compress, stream and show dense skeleton meshes on the web"};
  app.name("osteon");
  app.require_subcommand(1);
  app.set_version_flag("--version", "osteon 0.1.0");
  std::function<int()> run;
  register_info(app, &run);
  register_phantom(app, &run);
  register_encode(app, &run);
  register_decode(app, &run);
  register_segment(app, &run);
  register_compare(app, &run);
  register_segeval(app, &run);
  register_repeats(app, &run);
  register_serve(app, &run);
  register_pack(app, &run);
  register_export(app, &run);
  register_voxelize(app, &run);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    fail(e.what());
    std::fprintf(stderr, "Run 'osteon --help' or 'osteon <command> --help' for usage.\n");
    return kExitError;
  }
  if (!run) return fail("no command given; run 'osteon --help'");
  return run();
}
