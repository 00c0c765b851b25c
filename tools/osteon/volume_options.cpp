// SPDX-License-Identifier: Apache-2.0
#include "cli.hpp"

// The options every command that reads inputs takes for label volumes (osteon/volume.hpp).

namespace osteon::cli {

void add_volume_options(CLI::App* cmd, ReadOptions* options) {
  cmd->add_option("--labels", options->labels,
                  "label volumes: the labels to take, as values, names or the preset 'bones' "
                  "(comma-separated; default: every label present)")
      ->delimiter(',');
  cmd->add_option("--threshold", options->threshold,
                  "an intensity volume (a CT): the bone surface where the value is at least "
                  "this (Hounsfield units, e.g. 250), split into connected parts");
  cmd->add_option("--smoothing", options->smoothing_iterations,
                  "label volumes: constrained smoothing passes (default 16; 0: the voxel net)")
      ->check(CLI::Range(0, 1000));
  cmd->add_option("--surface-voxels", options->surface_precision_voxels,
                  "label volumes: simplify each surface to this fraction of the smallest voxel "
                  "side (pack's default 0.25; 0: keep every triangle)")
      ->check(CLI::Range(0.0, 100.0));
}

}  // namespace osteon::cli
