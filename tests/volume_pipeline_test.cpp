// SPDX-License-Identifier: Apache-2.0
// Label volumes through the whole pipeline: a real CT segmentation packs into named, coloured,
// watertight bones within one voxel of their labels; the raw CT is refused until given a
// threshold; meshes voxelized and surfaced again stay within one voxel of where they were.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "osteon/diagnose.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/io.hpp"
#include "osteon/pack.hpp"
#include "osteon/volume.hpp"

namespace osteon {
namespace {
namespace volume_pipeline_test {

namespace fs = std::filesystem;
using test::read_bytes;
using test::run_cli;
using test::scratch_dir;

std::string reference(const std::string& data, const char* file) {
  return data + "/wasserth__TotalSegmentator/tests/reference_files/" + file;
}

/// The largest symmetric distance from each surface to its label's voxel faces.
double distance_to_boundary(const LabelVolume& volume, const LabelSurface& surface) {
  Result<Mesh> faces = voxel_faces(volume, surface.value);
  EXPECT_TRUE(faces.ok()) << faces.status().message();
  if (!faces.ok()) return 1e9;
  HausdorffOptions options;
  options.samples_per_face = 4;
  Result<HausdorffReport> h = hausdorff(surface.mesh, faces.value(), options);
  EXPECT_TRUE(h.ok()) << h.status().message();
  return h.ok() ? h->symmetric.max : 1e9;
}

// The done-when case: TotalSegmentator's example segmentation, --labels bones.
TEST(VolumePipeline, TotalSegmentatorBonesAreSeventeenNamedWatertightParts) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string seg = reference(data, "example_seg.nii.gz");
  Result<LabelVolume> volume = read_volume(seg);
  ASSERT_TRUE(volume.ok()) << volume.status().message();
  Result<std::vector<uint32_t>> bones = select_labels(volume.value(), {"bones"});
  ASSERT_TRUE(bones.ok()) << bones.status().message();
  ASSERT_EQ(bones->size(), 17u) << "T11-L2, ribs 7-12 left and right, costal cartilages";
  SurfaceOptions options;
  options.labels = bones.value();
  Result<std::vector<LabelSurface>> surfaces = extract_surfaces(volume.value(), options);
  ASSERT_TRUE(surfaces.ok()) << surfaces.status().message();
  ASSERT_EQ(surfaces->size(), 17u);
  const double voxel = 3.0;  // mm, the file's spacing
  for (const LabelSurface& s : surfaces.value()) {
    const DiagnosisReport d = diagnose(s.mesh);
    EXPECT_TRUE(d.closed && d.oriented) << s.mesh.name;
    EXPECT_EQ(d.nonmanifold_vertices, 0u) << s.mesh.name;
    EXPECT_GT(d.volume, 0) << s.mesh.name << " faces outward";
    EXPECT_LE(distance_to_boundary(volume.value(), s), voxel) << s.mesh.name;
  }

  const std::string out = scratch_dir() + "/ct";
  const test::CliRun run =
      run_cli("pack " + seg + " --labels bones --no-viewer -o " + out + " --json");
  ASSERT_EQ(run.status, 0) << run.err;
  const std::vector<uint8_t> bytes = read_bytes(out + "/manifest.json");
  const nlohmann::json manifest = nlohmann::json::parse(bytes.begin(), bytes.end());
  ASSERT_EQ(manifest["parts"].size(), 17u);
  std::set<std::string> names;
  for (const nlohmann::json& part : manifest["parts"]) {
    names.insert(part["display_name"].get<std::string>());
    EXPECT_TRUE(part.contains("color")) << part["display_name"];
  }
  for (const char* bone :
       {"vertebrae_T11", "vertebrae_L2", "rib_left_7", "rib_right_12", "costal_cartilages"}) {
    EXPECT_TRUE(names.count(bone)) << bone;
  }
  // Upright and facing the viewer: the patient's axes travel with the package.
  EXPECT_EQ(manifest["view"]["up"], nlohmann::json::array({0, 0, 1}));
  EXPECT_EQ(manifest["view"]["eye"], nlohmann::json::array({0, -1, 0}));
  // What the viewer draws is still closed after the codec, and pack simplified it to a quarter
  // voxel: fewer triangles, each surface within a quarter voxel (and the codec's step) of the
  // extracted one.
  Result<Scene> drawn = read_path(out);
  ASSERT_TRUE(drawn.ok()) << drawn.status().message();
  uint64_t extracted = 0, packed = 0;
  for (const LabelSurface& s : surfaces.value()) extracted += s.mesh.triangle_count();
  for (const Mesh& part : drawn->parts) {
    EXPECT_TRUE(diagnose(part).closed) << part.name;
    packed += part.triangle_count();
  }
  EXPECT_LT(packed, extracted * 3 / 4);
  Scene full;
  for (const LabelSurface& s : surfaces.value()) full.parts.push_back(s.mesh);
  ASSERT_EQ(full.parts.size(), drawn->parts.size());
  for (size_t k = 0; k < full.parts.size(); ++k) {
    Result<HausdorffReport> h = hausdorff(full.parts[k], drawn->parts[k], HausdorffOptions{});
    ASSERT_TRUE(h.ok()) << h.status().message();
    EXPECT_LE(h->symmetric.max, 0.25 * voxel + 0.05) << full.parts[k].name;
  }
}

// The T11 vertebra lies above L2, and the left ribs on the patient's left (+x): the reader's
// RAS-to-LPS conversion.
TEST(VolumePipeline, CtSegmentationComesInThePatientsFrame) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  ReadOptions options;
  options.labels = {"vertebrae_T11", "vertebrae_L2", "rib_left_7", "rib_right_7"};
  Result<Scene> scene = read_path(reference(data, "example_seg.nii.gz"), options);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  std::map<std::string, Aabb> box;
  for (const Mesh& part : scene->parts) box[part.name] = bounding_box(part);
  ASSERT_EQ(box.size(), 4u);
  EXPECT_GT(box["vertebrae_T11"].min.z, box["vertebrae_L2"].max.z - 1);
  EXPECT_GT(box["rib_left_7"].min.x, 0);
  EXPECT_LT(box["rib_right_7"].max.x, 0);
  // The spine is behind the ribs' front ends: posterior is +y.
  EXPECT_GT(box["vertebrae_L2"].max.y, box["rib_left_7"].min.y);
}

TEST(VolumePipeline, RawCtIsRefusedWithoutAThresholdAndGivesBonesWithOne) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string ct = reference(data, "example_ct.nii.gz");
  const std::string out = scratch_dir() + "/ct";
  test::CliRun run = run_cli("pack " + ct + " --no-viewer -o " + out);
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("example_ct.nii.gz"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("intensity"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("--threshold"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(out + "/manifest.json"));

  ReadOptions options;
  options.threshold = 250;
  Result<Scene> bone = read_path(ct, options);
  ASSERT_TRUE(bone.ok()) << bone.status().message();
  ASSERT_GE(bone->parts.size(), 2u) << "split into connected parts";
  size_t triangles = 0;
  for (const Mesh& part : bone->parts) {
    triangles += part.triangle_count();
    EXPECT_TRUE(diagnose(part).closed) << part.name;
  }
  EXPECT_GT(triangles, 10000u);
  run = run_cli("pack " + ct + " --threshold 250 --no-viewer -o " + out);
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_TRUE(fs::exists(out + "/manifest.json"));
}

/// Bones voxelized at `voxel` mm and surfaced again: each within one voxel of the original. The
/// bones are ones the grid resolves (thicker than a voxel everywhere) and that do not touch each
/// other (a voxel inside two parts goes to one); bench/volume_bench measures every bone.
void expect_round_trip(const std::string& folder, const std::vector<std::string>& stems,
                       double voxel) {
  Result<Scene> scene = read_path(folder);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  Scene chosen;
  for (Mesh& part : scene->parts) {
    const std::string stem = fs::path(part.name).filename().string();
    for (const std::string& want : stems) {
      if (stem.find(want) != std::string::npos) chosen.parts.push_back(part);
    }
  }
  ASSERT_EQ(chosen.parts.size(), stems.size());
  const std::string file = scratch_dir() + "/bones.nii.gz";
  VoxelizeOptions voxelize_options;
  voxelize_options.voxel = voxel;
  ASSERT_TRUE(voxelize(chosen, file, voxelize_options).ok());
  Result<LabelVolume> volume = read_volume(file);
  ASSERT_TRUE(volume.ok()) << volume.status().message();
  Result<std::vector<LabelSurface>> surfaces = extract_surfaces(volume.value());
  ASSERT_TRUE(surfaces.ok()) << surfaces.status().message();
  ASSERT_EQ(surfaces->size(), chosen.parts.size());
  for (const LabelSurface& s : surfaces.value()) {
    const Mesh& original = chosen.parts.at(s.value - 1);
    EXPECT_TRUE(diagnose(s.mesh).closed) << original.name;
    HausdorffOptions options;
    options.samples_per_face = 2;
    Result<HausdorffReport> h = hausdorff(s.mesh, original, options);
    ASSERT_TRUE(h.ok()) << h.status().message();
    EXPECT_LE(h->symmetric.max, voxel)
        << original.name << ": forward " << h->forward.max << " at " << h->forward.max_at.x << ","
        << h->forward.max_at.y << "," << h->forward.max_at.z << ", backward " << h->backward.max;
  }
}

TEST(VolumePipeline, BodyParts3DVoxelizedAndSurfacedStaysWithinAVoxel) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  expect_round_trip(data + "/aHer-dev__3DAnatomy/models/bones",
                    {"Left_femur", "Right_tibia", "Left_humerus", "Third_lumbar_vertebra",
                     "Left_calcaneus", "Right_patella"},
                    1.0);
}

TEST(VolumePipeline, VisibleHumanBonesVoxelizedAndSurfacedStayWithinAVoxel) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  expect_round_trip(
      data + "/ingvilddevold__muscle-growth/data/VHF_surfaces",
      {"Left_Bone_Tibia", "Right_Bone_Calcaneous", "Left_Bone_Patella", "Right_Bone_Fibula"}, 1.0);
}

}  // namespace volume_pipeline_test
}  // namespace
}  // namespace osteon
