// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <nifti2_io.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "osteon/diagnose.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/io.hpp"
#include "osteon/volume.hpp"
#include "support/phantom.hpp"

// Meshes to label volumes (src/voxelize.cpp) and the NIfTI writer (src/volume_write.cpp): voxel
// counts of closed and open shapes, columns through edges and vertices, labels and names in the
// header, the orientation of the sform, thread independence, errors, the CLI. Files are read back
// with libnifti itself.

namespace osteon {
namespace {
namespace voxelize_test {

namespace fs = std::filesystem;

struct NiftiFree {
  void operator()(nifti_image* image) const { nifti_image_free(image); }
};
using NiftiPtr = std::unique_ptr<nifti_image, NiftiFree>;

/// A label volume as libnifti reads it back.
struct ReadBack {
  NiftiPtr image;
  std::vector<uint32_t> labels;  ///< one per voxel, x fastest
  std::string extension;         ///< the code-0 extension's text ("" when there is none)

  uint32_t at(size_t i, size_t j, size_t k) const {
    return labels[i + size_t(image->nx) * (j + size_t(image->ny) * k)];
  }
  /// The RAS+ world position of voxel (i, j, k) by the sform.
  std::array<double, 3> sform_world(size_t i, size_t j, size_t k) const {
    std::array<double, 3> out{};
    for (int r = 0; r < 3; ++r) {
      const double* m = image->sto_xyz.m[r];
      out[r] = m[0] * double(i) + m[1] * double(j) + m[2] * double(k) + m[3];
    }
    return out;
  }
};

ReadBack read_back(const std::string& path) {
  ReadBack out;
  out.image.reset(nifti_image_read(path.c_str(), 1));
  if (!out.image) {
    ADD_FAILURE() << "libnifti cannot read " << path;
    return out;
  }
  const nifti_image& nim = *out.image;
  out.labels.resize(nim.nvox);
  for (size_t i = 0; i < size_t(nim.nvox); ++i) {
    if (nim.datatype == DT_UINT8) {
      out.labels[i] = static_cast<const uint8_t*>(nim.data)[i];
    } else if (nim.datatype == DT_UINT16) {
      out.labels[i] = static_cast<const uint16_t*>(nim.data)[i];
    } else if (nim.datatype == DT_UINT32) {
      out.labels[i] = static_cast<const uint32_t*>(nim.data)[i];
    }
  }
  for (int e = 0; e < nim.num_ext; ++e) {
    if (nim.ext_list[e].ecode == 0)
      out.extension.assign(nim.ext_list[e].edata, size_t(nim.ext_list[e].esize) - 8);
  }
  return out;
}

uint64_t count_label(const ReadBack& volume, uint32_t label) {
  uint64_t n = 0;
  for (uint32_t l : volume.labels) n += l == label;
  return n;
}

/// The enclosed volume of a closed, outward-facing mesh (divergence theorem).
double mesh_volume(const Mesh& mesh) {
  double volume = 0;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    Vec3d a = to_double(mesh.positions[mesh.indices[3 * t]]);
    Vec3d b = to_double(mesh.positions[mesh.indices[3 * t + 1]]);
    Vec3d c = to_double(mesh.positions[mesh.indices[3 * t + 2]]);
    volume += dot(a, cross(b, c)) / 6.0;
  }
  return volume;
}

Mesh translated(Mesh mesh, Vec3 by) {
  for (Vec3& p : mesh.positions) p = {p.x + by.x, p.y + by.y, p.z + by.z};
  return mesh;
}

Mesh named(Mesh mesh, const std::string& name) {
  mesh.name = name;
  return mesh;
}

Scene scene_of(std::vector<Mesh> parts) {
  Scene scene;
  scene.parts = std::move(parts);
  return scene;
}

/// Voxelizes `scene` into `dir`/`file` and reads the result back.
ReadBack voxelize_and_read(const Scene& scene, double voxel, const std::string& file = "v.nii.gz",
                           VoxelizeReport* report = nullptr) {
  std::string path = test::scratch_dir() + "/" + file;
  VoxelizeOptions options;
  options.voxel = voxel;
  Status status = voxelize(scene, path, options, report);
  EXPECT_TRUE(status.ok()) << status.message();
  return read_back(path);
}

TEST(Voxelize, BoxesCountExactlyTheirVoxelCentres) {
  // Faces on voxel centres: the half-open rule counts each axis's first centre, not its last.
  ReadBack aligned = voxelize_and_read(scene_of({make_box({0, 0, 0}, {10, 10, 10})}), 0.5);
  EXPECT_EQ(count_label(aligned, 1), 20u * 20u * 20u);
  // Lower faces on centres (the grid starts at the minimum), upper faces between them:
  // 7.3 / 0.5 -> 15 centres, 5.2 -> 11, 9.1 -> 19.
  VoxelizeReport report;
  ReadBack offset = voxelize_and_read(scene_of({make_box({0.1f, 0.2f, 0.3f}, {7.4f, 5.4f, 9.4f})}),
                                      0.5, "o.nii", &report);
  EXPECT_EQ(count_label(offset, 1), 15u * 11u * 19u);
  EXPECT_EQ(report.labelled, 15u * 11u * 19u);
  // ceil(extent / voxel) + 2 * margin + 1 a side.
  EXPECT_EQ(report.size, (std::array<uint32_t, 3>{15 + 5, 11 + 5, 19 + 5}));
  EXPECT_EQ(report.voxels, 20u * 16u * 24u);
  ASSERT_TRUE(offset.image);
  EXPECT_EQ(offset.image->nx, 20);
  EXPECT_EQ(offset.image->datatype, DT_UINT8);
}

/// An independent inside test: the parity of the crossings of a ray from `p` in a direction no
/// triangle edge or vertex of these meshes lines up with (Moller-Trumbore, double precision).
bool inside_by_oblique_ray(const Mesh& mesh, const Vec3d& p) {
  const Vec3d d{0.5772156649, 0.3183098862, 0.7518796992};
  int crossings = 0;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    Vec3d a = to_double(mesh.positions[mesh.indices[3 * t]]);
    Vec3d e1 = to_double(mesh.positions[mesh.indices[3 * t + 1]]) - a;
    Vec3d e2 = to_double(mesh.positions[mesh.indices[3 * t + 2]]) - a;
    Vec3d h = cross(d, e2);
    double det = dot(e1, h);
    if (det == 0) continue;
    Vec3d s = p - a;
    double u = dot(s, h) / det;
    if (u < 0 || u > 1) continue;
    Vec3d q = cross(s, e1);
    double v = dot(d, q) / det;
    if (v < 0 || u + v > 1) continue;
    crossings += dot(e2, q) / det > 0;
  }
  return crossings % 2 == 1;
}

TEST(Voxelize, ClosedShapesMatchAnObliqueRayAndTheirVolume) {
  struct Case {
    const char* name;
    Mesh mesh;
    double voxel;
  };
  std::vector<Case> cases;
  cases.push_back({"sphere", make_icosphere(3, 5.0f), 0.5});
  cases.push_back({"torus (genus 1)", make_torus(4.0f, 1.5f, 48, 24), 0.25});
  cases.push_back({"small sphere", translated(make_icosphere(3, 3.7f), {1.3f, -2.1f, 0.4f}), 0.25});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    VoxelizeReport report;
    ReadBack v = voxelize_and_read(scene_of({c.mesh}), c.voxel, "v.nii.gz", &report);
    ASSERT_TRUE(v.image);
    // Voxel by voxel against the oblique ray (LPS centre = RAS centre with x and y negated),
    // but for centres on a vertex (the poles, on the grid's first planes), which are on the
    // surface: either answer is right there.
    const Aabb box = bounding_box(c.mesh);
    uint64_t differing = 0, on_vertex = 0;
    for (int k = 0; k < v.image->nz; ++k) {
      for (int j = 0; j < v.image->ny; ++j) {
        for (int i = 0; i < v.image->nx; ++i) {
          std::array<double, 3> ras = v.sform_world(i, j, k);
          const Vec3d p{-ras[0], -ras[1], ras[2]};
          if (p.x < box.min.x || p.y < box.min.y || p.z < box.min.z || p.x > box.max.x ||
              p.y > box.max.y || p.z > box.max.z) {
            differing += v.at(i, j, k) != 0;
            continue;
          }
          bool surface =
              std::any_of(c.mesh.positions.begin(), c.mesh.positions.end(),
                          [&](const Vec3& q) { return length(to_double(q) - p) < 1e-5; });
          on_vertex += surface;
          if (!surface) differing += inside_by_oblique_ray(c.mesh, p) != (v.at(i, j, k) == 1);
        }
      }
    }
    EXPECT_EQ(differing, 0u) << differing << " of " << report.labelled << " (" << on_vertex
                             << " centres on a vertex)";
    // The grid starts at the parts' minimum, so the extreme planes of voxel centres touch the
    // shape: round shapes count a little under their volume.
    const double expected = mesh_volume(c.mesh) / (c.voxel * c.voxel * c.voxel);
    EXPECT_NEAR(double(report.labelled), expected, 0.03 * expected);
  }
}

TEST(Voxelize, ColumnsThroughEdgesAndVerticesCountOnce) {
  // An octahedron with its vertices on voxel centres: the columns along x, y and z through its
  // middle pass exactly through two vertices each, and those in the planes x = 0, y = 0, z = 0
  // through its edges. Counting any of them twice (or not at all) flips a column beyond the
  // surface, the same column in every axis by symmetry, so the vote cannot hide it.
  const float r = 4;
  Mesh octahedron;
  octahedron.positions = {{r, 0, 0}, {-r, 0, 0}, {0, r, 0}, {0, -r, 0}, {0, 0, r}, {0, 0, -r}};
  octahedron.indices = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  ASSERT_GT(mesh_volume(octahedron), 0);
  ReadBack v = voxelize_and_read(scene_of({octahedron}), 1.0);
  ASSERT_TRUE(v.image);
  const int m = 2;  // the margin: voxel (m, m, m) is at (-r, -r, -r)
  uint64_t strictly_inside = 0, labelled = 0;
  for (int k = 0; k < v.image->nz; ++k) {
    for (int j = 0; j < v.image->ny; ++j) {
      for (int i = 0; i < v.image->nx; ++i) {
        int l1 = std::abs(i - m - int(r)) + std::abs(j - m - int(r)) + std::abs(k - m - int(r));
        bool in = v.at(i, j, k) == 1;
        labelled += in;
        if (l1 < r) {
          ++strictly_inside;
          EXPECT_TRUE(in) << i << " " << j << " " << k;
        }
        if (l1 > r) {
          EXPECT_FALSE(in) << i << " " << j << " " << k;
        }
      }
    }
  }
  EXPECT_GE(labelled, strictly_inside);
}

TEST(Voxelize, OpenSurfacesVoteLikeClosedOnes) {
  // Holes: a few triangles removed, apart from each other. A hole corrupts the columns through
  // it along one axis; the other two outvote it.
  Mesh closed = make_icosphere(3, 5.0f);
  Mesh open = closed;
  std::vector<uint32_t> kept;
  for (size_t t = 0; t < open.triangle_count(); ++t) {
    if (t % 211 == 17) continue;
    kept.insert(kept.end(), open.indices.begin() + 3 * t, open.indices.begin() + 3 * t + 3);
  }
  open.indices = kept;
  ASSERT_LT(open.triangle_count(), closed.triangle_count() - 4);
  ReadBack a = voxelize_and_read(scene_of({closed}), 0.5);
  ReadBack b = voxelize_and_read(scene_of({open}), 0.5);
  ASSERT_EQ(a.labels.size(), b.labels.size());
  uint64_t inside = count_label(a, 1), differing = 0;
  for (size_t i = 0; i < a.labels.size(); ++i) differing += a.labels[i] != b.labels[i];
  EXPECT_LT(double(differing), 0.01 * double(inside)) << differing << " of " << inside;

  // An open tube (both ends missing): rays across it see two walls, rays along it none, so
  // two of three votes fill the solid cylinder.
  Mesh tube = make_open_cylinder(3.0f, 8.0f, 64, 8);
  VoxelizeReport report;
  voxelize_and_read(scene_of({tube}), 0.25, "tube.nii.gz", &report);
  const double expected = std::numbers::pi * 9.0 * 8.0 / (0.25 * 0.25 * 0.25);
  EXPECT_NEAR(double(report.labelled), expected, 0.04 * expected);
}

TEST(Voxelize, TwoPartsGetLabelsOneAndTwoWithTheirNames) {
  Scene scene = scene_of({named(make_box({0, 0, 0}, {4, 4, 4}), "bones/Left_femur.stl"),
                          named(make_icosphere(2, 2.0f), "Right]]>femur")});
  scene.parts[1] = named(translated(scene.parts[1], {10, 2, 2}), "Right]]>femur");
  ReadBack v = voxelize_and_read(scene, 0.5);
  ASSERT_TRUE(v.image);
  EXPECT_EQ(count_label(v, 1), 8u * 8u * 8u);
  EXPECT_GT(count_label(v, 2), 100u);
  EXPECT_EQ(count_label(v, 3), 0u);
  EXPECT_EQ(v.image->intent_code, NIFTI_INTENT_LABEL);
  // The Caret XML label table as TotalSegmentator writes it.
  EXPECT_EQ(v.extension.rfind("<?xml version=\"1.0\" encoding=\"UTF-8\"?>", 0), 0u);
  EXPECT_NE(v.extension.find("<CaretExtension>"), std::string::npos);
  EXPECT_NE(v.extension.find("<VolumeInformation Index=\"0\">"), std::string::npos);
  EXPECT_NE(v.extension.find("<Label Key=\"1\""), std::string::npos);
  EXPECT_NE(v.extension.find("Alpha=\"1\"><![CDATA[Left_femur]]></Label>"), std::string::npos)
      << v.extension;
  // A "]]>" in a name is split across two CDATA sections.
  EXPECT_NE(v.extension.find("<Label Key=\"2\""), std::string::npos);
  EXPECT_NE(v.extension.find("<![CDATA[Right]]]]><![CDATA[>femur]]>"), std::string::npos)
      << v.extension;
}

TEST(Voxelize, PartsThinnerThanAVoxelKeepVoxelsAndComeBackNearTheirSurface) {
  // The box sets the grid (voxel centres on whole mm); the plate, 0.3 mm thick, lies between two
  // planes of centres, and the rod, 0.4 mm across, between four rows: neither holds a centre.
  Scene scene = scene_of({named(make_box({0, 0, 0}, {4, 4, 4}), "box"),
                          named(make_box({0, 6, 10.3f}, {8, 14, 10.6f}), "plate"),
                          named(make_box({10.3f, 0.3f, 0}, {10.7f, 0.7f, 9}), "rod")});
  const std::string path = test::scratch_dir() + "/thin.nii.gz";
  VoxelizeOptions options;
  options.voxel = 1;
  ASSERT_TRUE(voxelize(scene, path, options).ok());
  ReadBack v = read_back(path);
  ASSERT_TRUE(v.image);
  EXPECT_EQ(count_label(v, 1), 4u * 4u * 4u);  // a part the grid resolves keeps its inside only
  // One layer of voxels for the plate and its rim, not a layer for each face (they round to two
  // planes of centres); a column or two for the rod.
  EXPECT_GE(count_label(v, 2), 9u * 9u);
  EXPECT_LT(count_label(v, 2), 2u * 9u * 9u);
  EXPECT_GE(count_label(v, 3), 10u);
  EXPECT_LE(count_label(v, 3), 3u * 10u);
  Result<LabelVolume> volume = read_volume(path);
  ASSERT_TRUE(volume.ok()) << volume.status().message();
  Result<std::vector<LabelSurface>> surfaces = extract_surfaces(volume.value());
  ASSERT_TRUE(surfaces.ok()) << surfaces.status().message();
  ASSERT_EQ(surfaces->size(), 3u);
  for (const LabelSurface& s : surfaces.value()) {
    const Mesh& original = scene.parts.at(s.value - 1);
    EXPECT_TRUE(diagnose(s.mesh).closed) << original.name;
    if (s.value == 1) continue;
    // Each sample of the surface has a vertex of the extracted one in its grid cell; the
    // smoothed surface between them stays within a voxel and a half.
    Result<HausdorffReport> h = hausdorff(s.mesh, original, HausdorffOptions{});
    ASSERT_TRUE(h.ok()) << h.status().message();
    EXPECT_LE(h->symmetric.max, 1.5 * options.voxel) << original.name;
    EXPECT_LE(h->symmetric.mean, 0.6 * options.voxel) << original.name;
  }
}

TEST(Voxelize, SformTurnsOsteonsLeftPosteriorIntoRasNegatives) {
  // Part 1 at +x (patient left) and +y (posterior), part 2 at -x and -y (right, anterior).
  Scene scene =
      scene_of({make_box({10, 5, 1}, {20, 10, 3}), make_box({-20, -10, 1}, {-10, -5, 3})});
  ReadBack v = voxelize_and_read(scene, 0.5);
  ASSERT_TRUE(v.image);
  EXPECT_EQ(v.image->sform_code, NIFTI_XFORM_SCANNER_ANAT);
  EXPECT_EQ(v.image->qform_code, NIFTI_XFORM_SCANNER_ANAT);
  EXPECT_EQ(v.image->xyz_units, NIFTI_UNITS_MM);
  uint64_t seen[3] = {0, 0, 0};
  for (int k = 0; k < v.image->nz; ++k) {
    for (int j = 0; j < v.image->ny; ++j) {
      for (int i = 0; i < v.image->nx; ++i) {
        uint32_t label = v.at(i, j, k);
        if (label == 0) continue;
        ++seen[label];
        std::array<double, 3> ras = v.sform_world(i, j, k);
        if (label == 1) {
          ASSERT_TRUE(ras[0] <= -10 && ras[0] >= -20) << ras[0];
          ASSERT_TRUE(ras[1] <= -5 && ras[1] >= -10) << ras[1];
        } else {
          ASSERT_TRUE(ras[0] >= 10 && ras[0] <= 20) << ras[0];
          ASSERT_TRUE(ras[1] >= 5 && ras[1] <= 10) << ras[1];
        }
        ASSERT_TRUE(ras[2] >= 1 && ras[2] <= 3) << ras[2];
        // The qform says the same.
        for (int r = 0; r < 3; ++r) {
          const double* q = v.image->qto_xyz.m[r];
          double world = q[0] * double(i) + q[1] * double(j) + q[2] * double(k) + q[3];
          ASSERT_NEAR(world, ras[r], 1e-3);
        }
      }
    }
  }
  EXPECT_EQ(seen[1], 20u * 10u * 4u);
  EXPECT_EQ(seen[2], 20u * 10u * 4u);
  EXPECT_FLOAT_EQ(v.image->dx, 0.5f);
  EXPECT_FLOAT_EQ(v.image->dz, 0.5f);
}

TEST(Voxelize, OutputBytesDoNotDependOnTheThreadCount) {
  // Overlapping parts (the last wins) and more parts than threads.
  std::vector<Mesh> parts;
  for (int p = 0; p < 7; ++p)
    parts.push_back(translated(make_icosphere(2, 3.0f), {float(p) * 2.5f, float(p % 3), 0}));
  parts.push_back(make_torus(5.0f, 1.0f, 32, 12));
  Scene scene = scene_of(parts);
  std::string dir = test::scratch_dir();
  std::vector<uint8_t> first;
  for (int threads : {1, 2, 5}) {
    VoxelizeOptions options;
    options.voxel = 0.3;
    options.threads = threads;
    std::string path = dir + "/t" + std::to_string(threads) + ".nii.gz";
    ASSERT_TRUE(voxelize(scene, path, options).ok());
    std::vector<uint8_t> bytes = test::read_bytes(path);
    if (first.empty())
      first = bytes;
    else
      EXPECT_EQ(bytes, first) << threads << " threads";
  }
  // The last part wins where parts overlap: the torus (label 8) holds the first sphere's rim.
  ReadBack v = read_back(dir + "/t1.nii.gz");
  for (uint32_t label = 1; label <= 8; ++label) EXPECT_GT(count_label(v, label), 0u) << label;
}

TEST(Voxelize, ManyPartsTakeSixteenBitLabels) {
  std::vector<Mesh> parts;
  for (int p = 0; p < 300; ++p) {
    float x = float(p % 20) * 2, y = float(p / 20) * 2;
    parts.push_back(make_box({x, y, 0}, {x + 1, y + 1, 1}));
  }
  ReadBack v = voxelize_and_read(scene_of(parts), 0.5);
  ASSERT_TRUE(v.image);
  EXPECT_EQ(v.image->datatype, DT_UINT16);
  EXPECT_EQ(count_label(v, 1), 8u);
  EXPECT_EQ(count_label(v, 256), 8u);
  EXPECT_EQ(count_label(v, 300), 8u);
  EXPECT_NE(v.extension.find("<Label Key=\"300\""), std::string::npos);
}

TEST(Voxelize, BadArgumentsFailAndLeaveNoFile) {
  std::string dir = test::scratch_dir();
  Scene scene = scene_of({make_box({0, 0, 0}, {1, 1, 1})});
  for (double voxel : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    VoxelizeOptions options;
    options.voxel = voxel;
    Status status = voxelize(scene, dir + "/v.nii.gz", options);
    EXPECT_EQ(status.code(), ErrorCode::kInvalidArgument) << voxel;
    EXPECT_NE(status.message().find("voxel size"), std::string::npos) << status.message();
  }
  VoxelizeOptions tiny;
  tiny.voxel = 1e-7;  // 10^7 voxels a side: more than NIfTI-1's 32767
  EXPECT_EQ(voxelize(scene, dir + "/v.nii.gz", tiny).code(), ErrorCode::kInvalidArgument);
  tiny.voxel = 1e-12;  // over 2^31 a side
  Status huge = voxelize(scene, dir + "/v.nii.gz", tiny);
  EXPECT_EQ(huge.code(), ErrorCode::kInvalidArgument);
  EXPECT_NE(huge.message().find("2^31"), std::string::npos) << huge.message();
  EXPECT_EQ(voxelize(scene, dir + "/v.nrrd").code(), ErrorCode::kInvalidArgument);
  EXPECT_EQ(voxelize(Scene{}, dir + "/v.nii").code(), ErrorCode::kInvalidArgument);
  Scene nan_scene = scene;
  nan_scene.parts[0].positions[0].x = std::nanf("");
  EXPECT_EQ(voxelize(nan_scene, dir + "/v.nii").code(), ErrorCode::kInvalidArgument);
  Status missing = voxelize(scene, dir + "/no/such/folder/v.nii.gz");
  EXPECT_EQ(missing.code(), ErrorCode::kIoError);
  EXPECT_NE(missing.message().find("v.nii.gz"), std::string::npos) << missing.message();
  EXPECT_TRUE(fs::is_empty(dir));
}

TEST(Voxelize, WriteLabelVolumeKeepsValuesNamesAndTransform) {
  // A 3 x 2 x 2 volume of dense ids 0..2 standing for values 0, 7 and 300 (uint16 in the file).
  LabelVolume volume;
  volume.size = {3, 2, 2};
  volume.voxels = {0, 1, 2, 2, 1, 0, 1, 1, 1, 0, 0, 2};
  volume.values = {0, 7, 300};
  // Column-major: 2 mm along i, 3 mm along j, 4 mm along k, origin at (10, 20, 30) LPS.
  volume.index_to_world = {2, 0, 0, 0, 0, 3, 0, 0, 0, 0, 4, 0, 10, 20, 30, 1};
  VolumeLabel seven;
  seven.value = 7;
  seven.name = "sacrum";
  seven.has_color = true;
  seven.color = {1.0f, 0.5f, 0.25f};
  volume.table = {seven};
  std::string dir = test::scratch_dir();
  ASSERT_TRUE(write_label_volume(volume, dir + "/w.nii").ok());
  ReadBack v = read_back(dir + "/w.nii");
  ASSERT_TRUE(v.image);
  EXPECT_EQ(v.image->datatype, DT_UINT16);
  ASSERT_EQ(v.labels.size(), 12u);
  for (size_t i = 0; i < 12; ++i) EXPECT_EQ(v.labels[i], volume.values[volume.voxels[i]]) << i;
  EXPECT_NE(v.extension.find("Key=\"7\" Red=\"1\" Green=\"0.5\" Blue=\"0.25\" Alpha=\"1\">"
                             "<![CDATA[sacrum]]>"),
            std::string::npos)
      << v.extension;
  EXPECT_NE(v.extension.find("<![CDATA[label 300]]>"), std::string::npos) << v.extension;
  // RAS = LPS with x and y negated.
  std::array<double, 3> ras = v.sform_world(1, 1, 1);
  EXPECT_DOUBLE_EQ(ras[0], -12.0);
  EXPECT_DOUBLE_EQ(ras[1], -23.0);
  EXPECT_DOUBLE_EQ(ras[2], 34.0);
  // A plain .nii holds the header, the extensions and the voxels, nothing more.
  EXPECT_EQ(fs::file_size(dir + "/w.nii"), size_t(v.image->iname_offset) + 12 * 2);

  EXPECT_EQ(write_label_volume(volume, dir + "/w.nrrd").code(), ErrorCode::kInvalidArgument);
  volume.voxels.pop_back();
  EXPECT_EQ(write_label_volume(volume, dir + "/bad.nii").code(), ErrorCode::kInvalidArgument);
  volume.voxels.push_back(3);  // no value for dense id 3
  EXPECT_EQ(write_label_volume(volume, dir + "/bad.nii").code(), ErrorCode::kInvalidArgument);
  EXPECT_FALSE(fs::exists(dir + "/bad.nii"));
  EXPECT_FALSE(fs::exists(dir + "/w.nrrd"));
}

TEST(Voxelize, ReadVolumeReadsBackWhatWasWritten) {
  // osteon's own reader: the grid in osteon's frame, the labels and the names.
  Scene scene = scene_of({named(make_box({10, 5, 1}, {14, 7, 3}), "left/Left_rib.glb"),
                          named(make_box({-14, -7, 1}, {-10, -5, 3}), "Right_rib")});
  std::string path = test::scratch_dir() + "/r.nii.gz";
  VoxelizeOptions options;
  options.voxel = 0.5;
  ASSERT_TRUE(voxelize(scene, path, options).ok());
  Result<LabelVolume> read = read_volume(path);
  ASSERT_TRUE(read.ok()) << read.status().message();
  const LabelVolume& volume = read.value();
  // The first voxel centre is the parts' minimum less the margin, in LPS.
  Vec3d first = transform_point(volume.index_to_world, Vec3d{0, 0, 0});
  EXPECT_NEAR(first.x, -15, 1e-5);
  EXPECT_NEAR(first.y, -8, 1e-5);
  EXPECT_NEAR(first.z, 0, 1e-5);
  Vec3d step = transform_point(volume.index_to_world, Vec3d{1, 1, 1}) - first;
  EXPECT_NEAR(step.x, 0.5, 1e-6);
  EXPECT_NEAR(step.y, 0.5, 1e-6);
  ASSERT_GE(volume.table.size(), 2u);
  EXPECT_EQ(volume.table[0].value, 1u);
  EXPECT_EQ(volume.table[0].name, "Left_rib");
  EXPECT_EQ(volume.table[0].voxels, 8u * 4u * 4u);
  EXPECT_EQ(volume.table[1].name, "Right_rib");
  EXPECT_EQ(volume.table[1].voxels, 8u * 4u * 4u);

  // write_label_volume writes the same labels back; read again, they agree voxel for voxel.
  std::string again = test::scratch_dir() + "/again.nii";
  ASSERT_TRUE(write_label_volume(volume, again).ok());
  Result<LabelVolume> reread = read_volume(again);
  ASSERT_TRUE(reread.ok()) << reread.status().message();
  ASSERT_EQ(reread->voxel_count(), volume.voxel_count());
  for (size_t i = 0; i < volume.voxel_count(); ++i) {
    ASSERT_EQ(reread->values[reread->id(i)], volume.values[volume.id(i)]) << i;
  }
  EXPECT_EQ(reread->table[1].name, "Right_rib");
  EXPECT_EQ(reread->index_to_world, volume.index_to_world);
}

TEST(VoxelizeCli, WritesTheVolumeAndReportsJson) {
  std::string dir = test::scratch_dir();
  fs::create_directories(dir + "/bones");
  ASSERT_TRUE(write_mesh(dir + "/bones/a.stl", make_box({0, 0, 0}, {4, 4, 4})).ok());
  ASSERT_TRUE(write_mesh(dir + "/bones/b.ply", translated(make_icosphere(2, 2), {8, 2, 2})).ok());
  test::CliRun run =
      test::run_cli("voxelize " + dir + "/bones -o " + dir + "/out.nii.gz --voxel 0.5 --json");
  ASSERT_EQ(run.status, 0) << run.err;
  nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["parts"], 2);
  EXPECT_EQ(j["voxel"], 0.5);
  EXPECT_EQ(j["size"].size(), 3u);
  EXPECT_GT(j["labelled"].get<uint64_t>(), 8u * 8u * 8u);
  EXPECT_EQ(j["bytes"].get<uint64_t>(), fs::file_size(dir + "/out.nii.gz"));
  for (const char* key : {"output", "voxels", "ms", "margin"}) EXPECT_TRUE(j.contains(key)) << key;
  ReadBack v = read_back(dir + "/out.nii.gz");
  EXPECT_NE(v.extension.find("<![CDATA[a]]>"), std::string::npos) << v.extension;
  EXPECT_NE(v.extension.find("<![CDATA[b]]>"), std::string::npos) << v.extension;

  test::CliRun help = test::run_cli("voxelize --help");
  EXPECT_EQ(help.status, 0);
  EXPECT_NE(help.out.find("--voxel"), std::string::npos);
}

TEST(VoxelizeCli, ErrorsExitTwoAndLeaveNothing) {
  std::string dir = test::scratch_dir();
  ASSERT_TRUE(write_mesh(dir + "/a.stl", make_box({0, 0, 0}, {4, 4, 4})).ok());
  const std::string out = dir + "/out.nii.gz";
  for (const std::string& args : {"voxelize " + dir + "/a.stl -o " + dir + "/missing/out.nii.gz",
                                  "voxelize " + dir + "/nothing.stl -o " + out,
                                  "voxelize " + dir + "/a.stl -o " + out + " --voxel 0",
                                  "voxelize " + dir + "/a.stl -o " + out + " --voxel nan",
                                  "voxelize " + dir + "/a.stl -o " + dir + "/out.vtk"}) {
    test::CliRun run = test::run_cli(args);
    EXPECT_EQ(run.status, 2) << args;
    EXPECT_EQ(run.err.rfind("osteon: error: ", 0), 0u) << args << ": " << run.err;
  }
  std::vector<std::string> left;
  for (const auto& entry : fs::directory_iterator(dir)) left.push_back(entry.path().filename());
  EXPECT_EQ(left, std::vector<std::string>{"a.stl"});
}

}  // namespace voxelize_test
}  // namespace
}  // namespace osteon
