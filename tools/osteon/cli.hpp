// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>

#include "osteon/io.hpp"
#include "osteon/status.hpp"

// The pieces every subcommand shares: registration, the one error format, exit codes.

namespace osteon::cli {

/// Exit codes: 0 success, 2 any error (bad input, bad arguments, I/O).
constexpr int kExitOk = 0;
constexpr int kExitError = 2;

/// A subcommand registers its options on `app` and sets `*run` to the action run after parsing.
using Register = void (*)(CLI::App& app, std::function<int()>* run);

void register_info(CLI::App& app, std::function<int()>* run);
void register_phantom(CLI::App& app, std::function<int()>* run);
void register_encode(CLI::App& app, std::function<int()>* run);
void register_decode(CLI::App& app, std::function<int()>* run);
void register_segment(CLI::App& app, std::function<int()>* run);
void register_compare(CLI::App& app, std::function<int()>* run);
void register_segeval(CLI::App& app, std::function<int()>* run);
void register_repeats(CLI::App& app, std::function<int()>* run);
void register_serve(CLI::App& app, std::function<int()>* run);
void register_pack(CLI::App& app, std::function<int()>* run);
void register_export(CLI::App& app, std::function<int()>* run);
void register_voxelize(CLI::App& app, std::function<int()>* run);

/// Adds --labels, --threshold and --smoothing (label volumes) to a command that reads inputs.
void add_volume_options(CLI::App* cmd, ReadOptions* options);

/// Prints "osteon: error: <message>" to stderr and returns kExitError.
int fail(const Status& status);
int fail(const std::string& message);

/// True when stderr is a terminal (progress output is shown only then).
bool stderr_is_tty();

}  // namespace osteon::cli
