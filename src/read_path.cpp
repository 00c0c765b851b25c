// SPDX-License-Identifier: Apache-2.0
#include "osteon/io.hpp"
#include "osteon/package.hpp"

#include "io_internal.hpp"

// The one entry point for "any input": above the mesh readers (src/io*.cpp) and the package
// module (src/package), so that neither depends on the other. A package folder reads as the parts
// the viewer draws; everything else goes to the mesh readers.

namespace osteon {

Result<Scene> read_path(const std::string& path, const ReadOptions& options) {
  if (!is_package(path)) return read_meshes(path, options);
  OSTEON_ASSIGN_OR_RETURN(Scene scene, read_package(path));
  // The manifest's unit stands unless the caller gives one or it is unknown.
  const bool unit_known = !scene.parts.empty() && scene.parts.front().unit != Unit::kUnknown;
  if (options.unit != Unit::kUnknown || !unit_known) detail::assign_unit(options, &scene);
  return scene;
}

}  // namespace osteon
