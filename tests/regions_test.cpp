// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "osteon/mesh.hpp"
#include "package/package_internal.hpp"

namespace osteon::detail {
namespace {
namespace regions_test {

namespace fs = std::filesystem;

std::string joined(const std::vector<std::string>& path) {
  std::string out;
  for (const std::string& g : path) out += (out.empty() ? "" : " / ") + g;
  return out;
}

// TotalSegmentator's class names and Slicer's segment names place bones by their words.
TEST(Regions, ByTheWordsOfClassNames) {
  const std::map<std::string, std::string> expected = {
      {"vertebrae_T11", "Skeleton / Vertebral column / Thoracic"},
      {"vertebrae_C1", "Skeleton / Vertebral column / Cervical"},
      {"vertebrae_L5", "Skeleton / Vertebral column / Lumbar"},
      {"sacrum", "Skeleton / Vertebral column / Sacrum"},
      {"rib_left_7", "Skeleton / Thorax / Left / Ribs"},
      {"rib_right_12", "Skeleton / Thorax / Right / Ribs"},
      {"costal_cartilages", "Skeleton / Thorax / Costal cartilages"},
      {"sternum", "Skeleton / Thorax"},
      {"humerus_left", "Skeleton / Upper limb / Left"},
      {"scapula_right", "Skeleton / Upper limb / Right / Shoulder girdle"},
      {"clavicula_left", "Skeleton / Upper limb / Left / Shoulder girdle"},
      {"hip_right", "Skeleton / Pelvis / Right"},
      {"femur_left", "Skeleton / Lower limb / Left"},
      {"skull", "Skeleton / Skull"},
      {"Left femur", "Skeleton / Lower limb / Left"},
      {"Vertebra L1", "Skeleton / Vertebral column / Lumbar"},
      {"Rib 7 left", "Skeleton / Thorax / Left / Ribs"},
  };
  for (const auto& [name, path] : expected) {
    const Placement p = place_by_words(name);
    EXPECT_EQ(joined(p.path), path) << name;
    EXPECT_EQ(p.system, "Skeletal system") << name;
  }
  EXPECT_EQ(place_by_words("Intervertebral disc L4-L5").system, "Articular system");
  for (const char* soft : {"liver", "aorta", "kidney_left", "spleen"}) {
    EXPECT_TRUE(place_by_words(soft).path.empty()) << soft;
  }
}

/// A small ontology in BodyParts3D's table layout, with the loose parent the real one has: toe
/// phalanges are in "set of phalanges", which is in "skeleton of upper limb".
std::string write_ontology() {
  const std::string dir = test::scratch_dir() + "/fma";
  fs::create_directories(dir);
  test::write_bytes(dir + "/conventional_part_of.txt",
                    "\"id\"\tname\tpart id\tpart name\n"
                    "FMA1\thuman body\tFMA2\tskeletal system\n"
                    "FMA1\thuman body\tFMA3\tlower limb\n"
                    "FMA1\thuman body\tFMA7183\tupper limb\n"
                    "FMA7183\tupper limb\tFMA24139\tskeleton of upper limb\n"
                    "FMA24139\tskeleton of upper limb\tFMA231315\tset of phalanges\n"
                    "FMA3\tlower limb\tFMA9\tskeletal system of free lower limb\n"
                    "FMA3\tlower limb\tFMA10\tfoot\n"
                    "FMA10\tfoot\tFMA11\tset of toes\n"
                    "FMA11\tset of toes\tFMA32644\tmiddle phalanx of right third toe\n"
                    "FMA9\tskeletal system of free lower limb\tFMA32644\tmiddle phalanx of right "
                    "third toe\n"
                    "FMA3\tlower limb\tFMA24474\tright femur\n"
                    "FMA2\tskeletal system\tFMA24474\tright femur\n");
  test::write_bytes(dir + "/isa_element_parts.txt",
                    "concept id\tname\telement file id\n"
                    "FMA231315\tset of phalanges\tFJ104\n"
                    "FMA2\tskeletal system\tFJ104\n");
  test::write_bytes(dir + "/parts_list_e.txt", "\"id\"\ten\nFMA24474\tright femur\n");
  return dir;
}

TEST(Regions, TheNearestRegionInTheOntologyWins) {
  const std::string dir = write_ontology();
  const Result<std::vector<Placement>> placed = place_by_fma(
      dir, {"FJ104_BP62288_FMA32644_Middle_phalanx_of_right_third_toe",
            "FJ3171_BP1_FMA24474_Right_femur", "FJ1_no_fma_id", "FJ2_BP2_FMA999999_Unknown"});
  ASSERT_TRUE(placed.ok()) << placed.status().message();
  ASSERT_EQ(placed.value().size(), 4u);
  // The phalanx is one step below "skeletal system of free lower limb", two below "skeleton of
  // upper limb" (through its is-a "set of phalanges"): the lower limb, and its foot.
  EXPECT_EQ(joined(placed.value()[0].path), "Skeleton / Lower limb / Right / Foot");
  EXPECT_EQ(placed.value()[0].system, "Skeletal system");
  EXPECT_EQ(joined(placed.value()[1].path), "Skeleton / Lower limb / Right");
  EXPECT_TRUE(placed.value()[2].path.empty());
  EXPECT_TRUE(placed.value()[3].path.empty());
}

TEST(Regions, BadTablesNameTheFileAndLine) {
  const std::string dir = write_ontology();
  test::write_bytes(dir + "/parts_list_e.txt", "\"id\"\ten\nFMA24474\tright femur\nFMA7\n");
  Result<std::vector<Placement>> placed = place_by_fma(dir, {"FMA24474"});
  ASSERT_FALSE(placed.ok());
  EXPECT_NE(placed.status().message().find(dir + "/parts_list_e.txt: line 3: expected 2 "
                                           "tab-separated fields, got 1"),
            std::string::npos)
      << placed.status().message();
  placed = place_by_fma(dir + "/missing", {"FMA24474"});
  ASSERT_FALSE(placed.ok());
  EXPECT_NE(placed.status().message().find("missing/conventional_part_of.txt"), std::string::npos)
      << placed.status().message();

  Names names;
  const Status bad = derive_regions("ontology", {}, &names);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("--regions: expected \"names\""), std::string::npos);
}

// A part the names file places keeps its path; the others get the derived one.
TEST(Regions, TheNamesFileWins) {
  Names names;
  names.parts["femur_left"].path = {{"Legs", {}}};
  std::vector<Mesh> parts(3);
  parts[0].name = "femur_left";
  parts[1].name = "rib_right_3";
  parts[2].name = "liver";
  ASSERT_TRUE(derive_regions("names", parts, &names).ok());
  EXPECT_EQ(names.parts["femur_left"].path.size(), 1u);
  EXPECT_EQ(names.parts["femur_left"].system, "Skeletal system");
  ASSERT_EQ(names.parts["rib_right_3"].path.size(), 4u);
  EXPECT_EQ(names.parts["rib_right_3"].path[2].name, "Right");
  EXPECT_EQ(names.parts.count("liver"), 0u);
}

// The real BodyParts3D skeleton: every one of its 235 bones is placed in one of the six regions,
// the paired ones on their side, by the ontology's own tables.
TEST(Regions, BodyParts3DSkeletonFromItsOntology) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  std::vector<std::string> stems;
  for (const auto& entry :
       fs::directory_iterator(data + "/aHer-dev__3DAnatomy/models/bones")) {
    stems.push_back(stem_of(entry.path().filename().string()));
  }
  ASSERT_EQ(stems.size(), 235u);
  const Result<std::vector<Placement>> placed = place_by_fma(data + "/BodyParts3D-FMA", stems);
  ASSERT_TRUE(placed.ok()) << placed.status().message();
  std::map<std::string, size_t> per_region;
  std::map<std::string, std::string> path_of;
  for (size_t s = 0; s < stems.size(); ++s) {
    const Placement& p = placed.value()[s];
    ASSERT_GE(p.path.size(), 2u) << stems[s];
    ++per_region[p.path[1]];
    const std::string name = stems[s].substr(stems[s].find('_', stems[s].find("FMA")) + 1);
    path_of[name] = joined(p.path) + " | " + p.system;
    const bool right = name.find("Right_") == 0 || name.find("_right_") != std::string::npos;
    const bool left = name.find("Left_") == 0 || name.find("_left_") != std::string::npos;
    if (right || left) {
      EXPECT_EQ(p.path[2], right ? "Right" : "Left") << name;
    }
  }
  EXPECT_EQ(per_region.size(), 6u);
  size_t total = 0;
  for (const auto& [region, count] : per_region) total += count;
  EXPECT_EQ(total, 235u);
  EXPECT_EQ(path_of["Right_femur"], "Skeleton / Lower limb / Right | Skeletal system");
  EXPECT_EQ(path_of["Middle_phalanx_of_right_third_toe"],
            "Skeleton / Lower limb / Right / Foot | Skeletal system");
  EXPECT_EQ(path_of["Distal_phalanx_of_left_thumb"],
            "Skeleton / Upper limb / Left / Hand | Skeletal system");
  EXPECT_EQ(path_of["Left_scapula"],
            "Skeleton / Upper limb / Left / Shoulder girdle | Skeletal system");
  EXPECT_EQ(path_of["Frontal_bone"], "Skeleton / Skull | Skeletal system");
  EXPECT_EQ(path_of["Seventh_cervical_vertebra"],
            "Skeleton / Vertebral column / Cervical | Skeletal system");
  EXPECT_EQ(path_of["Intervertebral_disk_of_axis"],
            "Skeleton / Vertebral column / Intervertebral disks | Articular system");
  EXPECT_EQ(path_of["Left_fifth_costal_cartilage"],
            "Skeleton / Thorax / Left / Costal cartilages | Skeletal system");
  EXPECT_EQ(path_of["Right_hip_bone"], "Skeleton / Pelvis / Right | Skeletal system");
}

}  // namespace regions_test
}  // namespace
}  // namespace osteon::detail
