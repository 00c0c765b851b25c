// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "fixtures.hpp"

// The CLI as a user meets it: the real binary, its output, its exit status.

namespace osteon {
namespace {
namespace cli_test {

using test::CliRun;
using test::run_cli;

const char* kAsciiTetra =
    "solid tetra\n"
    "facet normal 0 0 -1\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\nendloop\nendfacet\n"
    "facet normal 0 -1 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 0 1\nendloop\nendfacet\n"
    "facet normal -1 0 0\nouter loop\nvertex 0 0 0\nvertex 0 0 1\nvertex 0 1 0\nendloop\nendfacet\n"
    "facet normal 1 1 1\nouter loop\nvertex 1 0 0\nvertex 0 1 0\nvertex 0 0 1\nendloop\nendfacet\n"
    "endsolid tetra\n";

TEST(Cli, EverySubcommandHasHelp) {
  for (const char* args : {"--help", "info --help", "phantom --help"}) {
    CliRun run = run_cli(args);
    EXPECT_EQ(run.status, 0) << args;
    EXPECT_NE(run.out.find("Usage"), std::string::npos) << args << ": " << run.out;
  }
}

// The encode report names the geometry's prediction mode: a decimated BodyParts3D bone codes
// with the tangent plane (mode bit 1), a triangle shape and the extrapolation; a Visible Human
// bone with the curvature step.
TEST(Cli, EncodeJsonReportsThePredictionMode) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string out = test::scratch_dir() + "/cartilage.ostm";
  CliRun run = run_cli("encode --json " + data +
                       "/aHer-dev__3DAnatomy/models/bones/"
                       "FJ646_BP62321_FMA7875_Right_first_costal_cartilage.glb -o " + out);
  ASSERT_EQ(run.status, 0) << run.err;
  nlohmann::json j = nlohmann::json::parse(run.out);
  for (const char* key : {"vertices", "triangles", "bytes", "geometry_bytes", "grid_step",
                          "prediction_mode", "encode_ms"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["prediction_mode"].get<int>() & 2, 2) << run.out;
  // A decimated bone's irregular triangles: a shape that shrinks the parallelogram's offset.
  ASSERT_TRUE(j["triangle_shape"].is_array() && j["triangle_shape"].size() == 2) << run.out;
  EXPECT_EQ(j["prediction_mode"].get<int>() & 4, 4) << run.out;
  EXPECT_LT(j["triangle_shape"][0].get<int>(), 16) << run.out;
  // Its vertices without parallelograms step out from their decoded neighbours (mode bit 3).
  ASSERT_TRUE(j["refinements"].is_array() && j["refinements"].size() == 2) << run.out;
  EXPECT_EQ(j["prediction_mode"].get<int>() & 8, 8) << run.out;
  EXPECT_GT(j["refinements"][0].get<int>(), 0) << run.out;
  // A smoothed isosurface of a curved bone: the prediction follows its neighbours' misses along
  // the normal (the curvature step).
  CliRun curved = run_cli("encode --json " + data +
                          "/ingvilddevold__muscle-growth/data/VHF_surfaces/Left/"
                          "VHF_Left_Bone_Talus_smooth.stl -o " + out);
  ASSERT_EQ(curved.status, 0) << curved.err;
  nlohmann::json k = nlohmann::json::parse(curved.out);
  EXPECT_EQ(k["prediction_mode"].get<int>() & 8, 8) << curved.out;
  EXPECT_GT(k["refinements"][1].get<int>(), 0) << curved.out;
}

// --effort 0: the encoder without its search, reported as such; an effort out of range is refused.
TEST(Cli, EncodeEffortZeroSkipsTheSearch) {
  std::string dir = test::scratch_dir();
  test::write_bytes(dir + "/tetra.stl", kAsciiTetra);
  CliRun fast = run_cli("encode --json --effort 0 " + dir + "/tetra.stl -o " + dir + "/fast.ostm");
  ASSERT_EQ(fast.status, 0) << fast.err;
  nlohmann::json j = nlohmann::json::parse(fast.out);
  EXPECT_EQ(j["effort"], 0);
  EXPECT_EQ(j["geometry_passes"], 1.0);
  EXPECT_EQ(j["connectivity_models"], 1);
  CliRun back = run_cli("decode " + dir + "/fast.ostm -o " + dir + "/fast.ply");
  EXPECT_EQ(back.status, 0) << back.err;
  CliRun bad = run_cli("encode --effort 2 " + dir + "/tetra.stl -o " + dir + "/bad.ostm");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.err.find("--effort"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.ostm"));
}

TEST(Cli, InfoJsonHasTheDocumentedFields) {
  std::string dir = test::scratch_dir();
  test::write_bytes(dir + "/tetra.stl", kAsciiTetra);
  CliRun run = run_cli("info --json " + dir + "/tetra.stl");
  ASSERT_EQ(run.status, 0) << run.err;
  nlohmann::json j = nlohmann::json::parse(run.out);
  for (const char* key :
       {"vertices", "triangles", "components", "boundary_edges", "nonmanifold_edges",
        "degenerate_triangles", "bbox_min", "bbox_max", "area", "parts"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["vertices"], 4);
  EXPECT_EQ(j["stored_vertices"], 12);
  EXPECT_EQ(j["triangles"], 4);
  EXPECT_EQ(j["components"], 1);
  EXPECT_EQ(j["boundary_edges"], 0);
  EXPECT_EQ(j["euler"], 2);
  EXPECT_EQ(j["genus"], 0);
  EXPECT_EQ(j["bbox_max"], nlohmann::json({1.0, 1.0, 1.0}));
  ASSERT_EQ(j["parts"].size(), 1u);
  EXPECT_EQ(j["parts"][0]["name"], "tetra");
  EXPECT_EQ(j["parts"][0]["format"], "stl");
  EXPECT_NEAR(j["volume"].get<double>(), 1.0 / 6.0, 1e-9);
}

TEST(Cli, InfoSumsSeveralPathsIntoATotal) {
  std::string dir = test::scratch_dir();
  test::write_bytes(dir + "/a.stl", kAsciiTetra);
  test::write_bytes(dir + "/b.stl", kAsciiTetra);
  CliRun run = run_cli("info --json " + dir + "/a.stl " + dir);
  ASSERT_EQ(run.status, 0) << run.err;
  nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["parts"].size(), 3u);
  EXPECT_EQ(j["triangles"], 12);
  EXPECT_EQ(j["components"], 3);
  CliRun table = run_cli("info " + dir);
  ASSERT_EQ(table.status, 0);
  EXPECT_NE(table.out.find("total (2 parts)"), std::string::npos) << table.out;
}

TEST(Cli, ErrorsNameTheFileAndExitWithTwo) {
  CliRun missing = run_cli("info /nonexistent/femur.stl");
  EXPECT_EQ(missing.status, 2);
  EXPECT_EQ(missing.err, "osteon: error: /nonexistent/femur.stl: no such file or folder\n");
  EXPECT_TRUE(missing.out.empty());

  std::string dir = test::scratch_dir();
  test::write_bytes(dir + "/cut.stl", std::string(kAsciiTetra).substr(0, 60));
  CliRun cut = run_cli("info " + dir + "/cut.stl");
  EXPECT_EQ(cut.status, 2);
  EXPECT_EQ(cut.err.rfind("osteon: error: " + dir + "/cut.stl: ", 0), 0u) << cut.err;
  EXPECT_NE(cut.err.find("(line "), std::string::npos) << cut.err;

  CliRun bad_flag = run_cli("info --no-such-flag x.stl");
  EXPECT_EQ(bad_flag.status, 2);
  EXPECT_EQ(bad_flag.err.rfind("osteon: error: ", 0), 0u) << bad_flag.err;

  CliRun no_command = run_cli("");
  EXPECT_EQ(no_command.status, 2);
  CliRun bad_unit = run_cli("info --unit furlong " + dir + "/cut.stl");
  EXPECT_EQ(bad_unit.status, 2);
  EXPECT_NE(bad_unit.err.find("unknown unit 'furlong'"), std::string::npos);
}

TEST(Cli, PhantomWritesPartsAndTruthThatInfoReads) {
  std::string dir = test::scratch_dir() + "/phantom";
  CliRun run = run_cli("phantom --detail 2 -o " + dir);
  ASSERT_EQ(run.status, 0) << run.err;
  ASSERT_TRUE(std::filesystem::exists(dir + "/truth.json"));
  auto truth_bytes = test::read_bytes(dir + "/truth.json");
  nlohmann::json truth = nlohmann::json::parse(truth_bytes.begin(), truth_bytes.end());
  ASSERT_GT(truth["parts"].size(), 5u);
  CliRun info = run_cli("info --json " + dir);
  ASSERT_EQ(info.status, 0) << info.err;
  nlohmann::json j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["parts"].size(), truth["parts"].size());
  // Parts come back sorted by name; check each one's truth by name.
  for (const auto& part : j["parts"]) {
    for (const auto& t : truth["parts"]) {
      if (t["name"] != part["name"]) continue;
      EXPECT_EQ(part["triangles"], t["triangles"]) << t["name"];
      EXPECT_EQ(part["nonmanifold_edges"], t["nonmanifold_edges"]) << t["name"];
      EXPECT_EQ(part["boundary_loops"], t["boundary_loops"]) << t["name"];
      if (t["nonmanifold_edges"] == 0) {
        EXPECT_EQ(part["genus"], t["genus"]) << t["name"];
      }
    }
  }
  // Same seed, same bytes.
  std::string again = test::scratch_dir() + "/again";
  ASSERT_EQ(run_cli("phantom --detail 2 -o " + again).status, 0);
  for (const auto& t : truth["parts"]) {
    std::string file = t["file"];
    EXPECT_EQ(test::read_bytes(dir + "/" + file), test::read_bytes(again + "/" + file)) << file;
  }
}

TEST(Cli, PhantomRejectsBadOptions) {
  CliRun run = run_cli("phantom --detail 9 -o " + test::scratch_dir());
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("--detail"), std::string::npos);
}

}  // namespace cli_test
}  // namespace
}  // namespace osteon
