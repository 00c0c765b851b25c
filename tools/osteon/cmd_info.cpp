// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli.hpp"
#include "osteon/diagnose.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"

// osteon info PATH... [--json]: read, weld, diagnose; one row per part and a total.

namespace osteon::cli {

namespace {

struct InfoArgs {
  std::vector<std::string> paths;
  bool json = false;
  bool no_weld = false;
  float weld_tolerance = 0;
  bool drop_degenerate = false;
  bool components = false;
  std::string unit;
  ReadOptions read;  ///< label volumes' options
};

nlohmann::json vec_json(const Vec3& v) {
  return {v.x, v.y, v.z};
}

nlohmann::json component_json(const ComponentReport& c) {
  return {{"vertices", c.vertices},
          {"triangles", c.triangles},
          {"edges", c.edges},
          {"boundary_edges", c.boundary_edges},
          {"boundary_loops", c.boundary_loops},
          {"nonmanifold_edges", c.nonmanifold_edges},
          {"nonmanifold_vertices", c.nonmanifold_vertices},
          {"inconsistent_edges", c.inconsistent_edges},
          {"euler", c.euler},
          {"genus", c.genus},
          {"closed", c.closed},
          {"bbox_min", vec_json(c.bbox.min)},
          {"bbox_max", vec_json(c.bbox.max)},
          {"area", c.area},
          {"volume", c.volume}};
}

// The fields of a part's (or the total's) JSON object.
nlohmann::json report_json(const DiagnosisReport& r, size_t stored_vertices,
                           size_t degenerate_removed) {
  nlohmann::json j = {{"stored_vertices", stored_vertices},
                      {"vertices", r.vertices},
                      {"unreferenced_vertices", r.unreferenced_vertices},
                      {"triangles", r.triangles},
                      {"degenerate_triangles", r.degenerate_triangles + degenerate_removed},
                      {"degenerate_triangles_removed", degenerate_removed},
                      {"components", r.components},
                      {"edges", r.edges},
                      {"boundary_edges", r.boundary_edges},
                      {"boundary_loops", r.boundary_loops},
                      {"nonmanifold_edges", r.nonmanifold_edges},
                      {"nonmanifold_vertices", r.nonmanifold_vertices},
                      {"inconsistent_edges", r.inconsistent_edges},
                      {"euler", r.euler},
                      {"genus", r.genus},
                      {"closed", r.closed},
                      {"oriented", r.oriented},
                      {"bbox_min", vec_json(r.bbox.min)},
                      {"bbox_max", vec_json(r.bbox.max)},
                      {"area", r.area},
                      {"volume", r.volume}};
  return j;
}

struct PartInfo {
  const Mesh* mesh;
  DiagnosisReport report;
  size_t degenerate_removed = 0;
};

// Sums the parts into one report (components and counts add; the bbox is the union).
DiagnosisReport total_of(const std::vector<PartInfo>& parts, size_t* stored, size_t* removed) {
  DiagnosisReport t;
  t.genus = 0;
  t.closed = true;
  t.oriented = true;
  *stored = 0;
  *removed = 0;
  for (const PartInfo& p : parts) {
    const DiagnosisReport& r = p.report;
    *stored += p.mesh->stored_vertices;
    *removed += p.degenerate_removed;
    t.vertices += r.vertices;
    t.unreferenced_vertices += r.unreferenced_vertices;
    t.triangles += r.triangles;
    t.degenerate_triangles += r.degenerate_triangles;
    t.components += r.components;
    t.edges += r.edges;
    t.boundary_edges += r.boundary_edges;
    t.boundary_loops += r.boundary_loops;
    t.nonmanifold_edges += r.nonmanifold_edges;
    t.nonmanifold_vertices += r.nonmanifold_vertices;
    t.inconsistent_edges += r.inconsistent_edges;
    t.euler += r.euler;
    t.genus = (t.genus < 0 || r.genus < 0) ? -1 : t.genus + r.genus;
    t.closed = t.closed && r.closed;
    t.oriented = t.oriented && r.oriented;
    t.area += r.area;
    t.volume += r.volume;
    expand(t.bbox, r.bbox);
  }
  return t;
}

void print_row(const std::string& name, const DiagnosisReport& r, size_t stored, size_t removed) {
  std::string genus = r.genus < 0 ? "-" : std::to_string(r.genus);
  std::printf("%-44s %9zu %9zu %9zu %5zu %5zu %7zu %7zu %6zu %6zu %6ld %5s %-6s %.6g\n",
              name.size() > 44 ? ("..." + name.substr(name.size() - 41)).c_str() : name.c_str(),
              stored, r.vertices, r.triangles, r.degenerate_triangles + removed, r.components,
              r.boundary_edges, r.boundary_loops, r.nonmanifold_edges, r.inconsistent_edges,
              r.euler, genus.c_str(), r.closed ? "yes" : "no", r.area);
}

int run_info(const InfoArgs& args) {
  ReadOptions read_options = args.read;
  read_options.weld = !args.no_weld && args.weld_tolerance <= 0;
  if (!args.unit.empty() && !parse_unit(args.unit, &read_options.unit)) {
    return fail("--unit: unknown unit '" + args.unit + "' (use mm, cm, m or in)");
  }
  if (args.weld_tolerance < 0) return fail("--weld-tolerance must not be negative");

  std::vector<std::unique_ptr<Scene>> scenes;
  std::vector<PartInfo> parts;
  for (const std::string& path : args.paths) {
    Result<Scene> scene = read_path(path, read_options);
    if (!scene.ok()) return fail(scene.status());
    scenes.push_back(std::make_unique<Scene>(std::move(scene).value()));
    for (Mesh& mesh : scenes.back()->parts) {
      if (args.weld_tolerance > 0) weld(mesh, WeldOptions{args.weld_tolerance});
      PartInfo info{&mesh, {}, 0};
      if (args.drop_degenerate) info.degenerate_removed = remove_degenerate_triangles(mesh);
      info.report = diagnose(mesh);
      parts.push_back(std::move(info));
    }
  }
  size_t total_stored = 0, total_removed = 0;
  DiagnosisReport total = total_of(parts, &total_stored, &total_removed);
  const Mesh& first = *parts.front().mesh;

  if (args.json) {
    nlohmann::json out = report_json(total, total_stored, total_removed);
    out["unit"] = unit_name(first.unit);
    out["unit_guessed"] = first.unit_source == UnitSource::kGuessed;
    out["parts"] = nlohmann::json::array();
    for (const PartInfo& p : parts) {
      nlohmann::json j = {{"name", p.mesh->name},
                          {"source", p.mesh->source},
                          {"format", format_name(format_from_extension(p.mesh->source))}};
      j.update(report_json(p.report, p.mesh->stored_vertices, p.degenerate_removed));
      if (args.components) {
        j["component_reports"] = nlohmann::json::array();
        for (const ComponentReport& c : p.report.component_reports) {
          j["component_reports"].push_back(component_json(c));
        }
      }
      out["parts"].push_back(std::move(j));
    }
    std::cout << out.dump(2) << "\n";
    return kExitOk;
  }

  std::printf("%-44s %9s %9s %9s %5s %5s %7s %7s %6s %6s %6s %5s %-6s %s\n", "part", "stored_v",
              "vertices", "triangles", "degen", "comps", "bnd_edg", "bnd_lps", "nm_edg", "incons",
              "euler", "genus", "closed", "area");
  for (const PartInfo& p : parts) {
    print_row(p.mesh->name, p.report, p.mesh->stored_vertices, p.degenerate_removed);
  }
  if (parts.size() > 1) {
    print_row("total (" + std::to_string(parts.size()) + " parts)", total, total_stored,
              total_removed);
  }
  // A signed volume means something only for closed parts; open ones are left out of this line.
  double closed_volume = 0;
  size_t closed_parts = 0;
  for (const PartInfo& p : parts) {
    if (!p.report.closed) continue;
    closed_volume += p.report.volume;
    ++closed_parts;
  }
  std::printf("bbox [%g %g %g] - [%g %g %g] %s%s; volume of the %zu closed parts %.6g\n",
              total.bbox.min.x, total.bbox.min.y, total.bbox.min.z, total.bbox.max.x,
              total.bbox.max.y, total.bbox.max.z, unit_name(first.unit),
              first.unit_source == UnitSource::kGuessed ? " (unit guessed from size)" : "",
              closed_parts, closed_volume);
  return kExitOk;
}

}  // namespace

void register_info(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<InfoArgs>();
  CLI::App* cmd = app.add_subcommand(
      "info", "Read meshes (files or folders of parts) and report their topology and size");
  cmd->add_option("PATH", args->paths,
                  "Mesh files (.stl .obj .ply .off .vtk .gltf .glb) or folders")
      ->required();
  cmd->add_flag("--json", args->json, "Print JSON (per part and in total) instead of a table");
  add_volume_options(cmd, &args->read);
  cmd->add_flag("--no-weld", args->no_weld,
                "Keep the vertices as stored (an STL then has 3 per triangle)");
  cmd->add_option("--weld-tolerance", args->weld_tolerance,
                  "Also merge vertices closer than this (mesh units)");
  cmd->add_flag("--drop-degenerate", args->drop_degenerate,
                "Remove degenerate triangles (repeated index or zero area) before diagnosing");
  cmd->add_flag("--components", args->components, "With --json: list every connected component");
  cmd->add_option("--unit", args->unit, "The unit of the input (mm, cm, m, in); default: guessed");
  cmd->callback([args, run] { *run = [args] { return run_info(*args); }; });
}

}  // namespace osteon::cli
