#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
# Writes the bad_*.json golden manifests and expected.json from the valid_*.json ones (README.md):
# each bad file is valid_named_subset.json with one field broken, written back in the packer's own
# form (compact, keys sorted, numbers as they were), so it differs from the valid file in that
# field alone. Run it after regenerating the valid files:
#
#   python3 tests/data/manifests/make_bad.py

import json
import os

here = os.path.dirname(os.path.abspath(__file__))


def load(name):
    with open(os.path.join(here, name), encoding="utf-8") as f:
        return json.load(f)


def dump(name, manifest):
    text = json.dumps(manifest, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    with open(os.path.join(here, name), "w", encoding="utf-8") as f:
        f.write(text + "\n")


def swap_box(box):
    box["min"], box["max"] = box["max"], box["min"]


base = load("valid_named_subset.json")
chunk1 = base["chunks"][1]["file"]
assert base["components"][2]["chunk"] == 1 and base["components"][2]["offset"] + base["components"][2]["bytes"] <= base["chunks"][1]["bytes"]

# name -> (the JSON path the error must name, the edit). JSON has no NaN or Infinity, and a number
# too large for a double (1e999) is an error of the JSON reader itself (nlohmann::json refuses it,
# JavaScript reads Infinity), so null stands in for a non-finite number.
bad = {
    "bad_format.json": ("format", lambda m: m.update(format="osteon-mesh")),
    "bad_version.json": ("version", lambda m: m.update(version=1)),
    "bad_stream_version.json": ("stream_version", lambda m: m.update(stream_version=9)),
    "bad_unit.json": ("unit", lambda m: m.update(unit="furlong")),
    "bad_missing_chunks.json": ("chunks", lambda m: m.pop("chunks")),
    "bad_instances_not_array.json": ("instances", lambda m: m.update(instances={})),
    "bad_bounds_min_above_max.json": ("bounds", lambda m: swap_box(m["bounds"])),
    "bad_chunk_file_traversal.json": ("chunks[1].file", lambda m: m["chunks"][1].update(file="../" + chunk1)),
    "bad_chunk_file_absolute.json": ("chunks[0].file", lambda m: m["chunks"][0].update(file="/" + m["chunks"][0]["file"])),
    "bad_chunk_file_extension.json": ("chunks[1].file", lambda m: m["chunks"][1].update(file=chunk1[:-len(".ostc")] + ".ostm")),
    "bad_chunk_file_duplicate.json": ("chunks[3].file", lambda m: m["chunks"][3].update(file=m["chunks"][0]["file"])),
    "bad_part_id.json": ("parts[1].id", lambda m: m["parts"][1].update(id=0)),
    "bad_part_name_number.json": ("parts[2].name", lambda m: m["parts"][2].update(name=7)),
    "bad_part_prototype_out_of_range.json": ("parts[3].prototype", lambda m: m["parts"][3].update(prototype=len(m["parts"]))),
    "bad_component_duplicate_id.json": ("components[3].id", lambda m: m["components"][3].update(id=m["components"][2]["id"])),
    "bad_component_chunk_out_of_range.json": ("components[1].chunk", lambda m: m["components"][1].update(chunk=len(m["chunks"]))),
    "bad_component_offset_string.json": ("components[2].offset", lambda m: m["components"][2].update(offset=str(m["components"][2]["offset"]))),
    # offset + bytes beyond the chunk's bytes: named at .bytes (the range's end is what overflows).
    "bad_component_range_outside_chunk.json": ("components[2].bytes", lambda m: m["components"][2].update(offset=m["chunks"][1]["bytes"] - m["components"][2]["bytes"] + 1)),
    # An offset at the chunk's end (an empty range there, then its bytes) is named at .bytes too.
    "bad_component_offset_at_chunk_end.json": ("components[2].bytes", lambda m: m["components"][2].update(offset=m["chunks"][1]["bytes"])),
    "bad_view_parallel.json": ("view", lambda m: m.update(view={"up": [0, 0, 1], "eye": [0, 0, -2]})),
    "bad_view_eye_short.json": ("view.eye", lambda m: m.update(view={"up": [0, 0, 1], "eye": [0, 1]})),
    "bad_part_color_short.json": ("parts[1].color", lambda m: m["parts"][1].update(color=[0.5, 0.5])),
    "bad_part_color_range.json": ("parts[2].color[1]", lambda m: m["parts"][2].update(color=[0.5, 1.5, 0.5])),
    # An offset past the chunk's end is named at .offset itself.
    "bad_component_offset_past_chunk_end.json": ("components[2].offset", lambda m: m["components"][2].update(offset=m["chunks"][1]["bytes"] + 1)),
    "bad_component_bounds_null.json": ("components[4].bounds.max[1]", lambda m: m["components"][4]["bounds"]["max"].__setitem__(1, None)),
    "bad_component_bounds_min_above_max.json": ("components[5].bounds", lambda m: swap_box(m["components"][5]["bounds"])),
    "bad_instance_part_out_of_range.json": ("instances[5].part", lambda m: m["instances"][5].update(part=len(m["parts"]))),
    "bad_instance_unknown_component.json": ("instances[3].component", lambda m: m["instances"][3].update(component="c99")),
    "bad_instance_matrix_15.json": ("instances[1].matrix", lambda m: m["instances"][1]["matrix"].pop()),
    "bad_instance_matrix_string.json": ("instances[1].matrix[12]", lambda m: m["instances"][1]["matrix"].__setitem__(12, "0")),
    "bad_instance_matrix_singular.json": ("instances[0].matrix", lambda m: m["instances"][0].update(matrix=[0.0] * 16)),
    "bad_stream_order_unknown.json": ("stream_order[3]", lambda m: m["stream_order"].__setitem__(3, "c99")),
    # A repeat replaces the last entry, so that component is missing too: entries are checked
    # first, in order, and the duplicate is named.
    "bad_stream_order_duplicate.json": ("stream_order[6]", lambda m: m["stream_order"].__setitem__(6, m["stream_order"][0])),
    "bad_stream_order_missing.json": ("stream_order", lambda m: m["stream_order"].pop()),
}

# Levels of detail: valid_levels.json with one level field broken (component 1, the skull, has
# two levels in chunks 0 and 1).
levels_base = load("valid_levels.json")
assert len(levels_base["components"][1]["levels"]) == 2
bad_levels = {
    "bad_levels_not_array.json": ("components[1].levels", lambda m: m["components"][1].update(levels={})),
    "bad_level_not_object.json": ("components[1].levels[0]", lambda m: m["components"][1]["levels"].__setitem__(0, 7)),
    "bad_level_chunk_out_of_range.json": ("components[1].levels[1].chunk", lambda m: m["components"][1]["levels"][1].update(chunk=len(m["chunks"]))),
    "bad_level_range_outside_chunk.json": ("components[1].levels[0].bytes", lambda m: m["components"][1]["levels"][0].update(bytes=m["chunks"][0]["bytes"])),
    "bad_level_error_below_bound.json": ("components[0].levels[0].error", lambda m: m["components"][0]["levels"][0].update(error=0)),
    # A coarser level with as many triangles as the next finer one.
    "bad_level_triangles_not_fewer.json": ("components[1].levels[0].triangles", lambda m: m["components"][1]["levels"][0].update(triangles=m["components"][1]["levels"][1]["triangles"])),
    "bad_level_triangles_of_full.json": ("components[0].levels[0].triangles", lambda m: m["components"][0]["levels"][0].update(triangles=m["components"][0]["triangles"] + 1)),
}

# Groups and languages: valid_regions.json (languages en, la, ja; five groups, Skeleton >
# Lower limb > Left / Right and Skeleton > Vertebral column; parts 0 and 1 with names) with one
# of them broken.
regions_base = load("valid_regions.json")
assert regions_base["languages"] == ["en", "la", "ja"] and len(regions_base["groups"]) == 5
bad_regions = {
    "bad_languages_not_array.json": ("languages", lambda m: m.update(languages="en")),
    "bad_languages_tag.json": ("languages[1]", lambda m: m["languages"].__setitem__(1, "latin language")),
    "bad_languages_duplicate.json": ("languages[2]", lambda m: m["languages"].__setitem__(2, "en")),
    "bad_languages_too_many.json": ("languages", lambda m: m.update(languages=["en"] + ["x%02d" % k for k in range(64)])),
    "bad_groups_not_array.json": ("groups", lambda m: m.update(groups={})),
    "bad_group_not_object.json": ("groups[2]", lambda m: m["groups"].__setitem__(2, "Left")),
    "bad_group_name_empty.json": ("groups[1].name", lambda m: m["groups"][1].update(name="")),
    # A parent must come earlier: itself, or a later group, would allow a cycle.
    "bad_group_parent_self.json": ("groups[2].parent", lambda m: m["groups"][2].update(parent=2)),
    "bad_group_parent_later.json": ("groups[1].parent", lambda m: m["groups"][1].update(parent=4)),
    "bad_group_parent_negative.json": ("groups[1].parent", lambda m: m["groups"][1].update(parent=-1)),
    "bad_group_too_deep.json": ("groups[32].parent", lambda m: m.update(groups=[{"name": "Skeleton"}] + [{"name": "g%d" % k, "parent": k} for k in range(32)])),
    "bad_group_names_language.json": ("groups[1].names.de", lambda m: m["groups"][1]["names"].update(de="Untere Extremitaet")),
    "bad_group_names_number.json": ("groups[0].names.la", lambda m: m["groups"][0]["names"].update(la=7)),
    "bad_part_path_out_of_range.json": ("parts[3].path", lambda m: m["parts"][3].update(path=5)),
    "bad_part_path_string.json": ("parts[1].path", lambda m: m["parts"][1].update(path="2")),
    "bad_part_names_not_object.json": ("parts[0].names", lambda m: m["parts"][0].update(names=["Femur sinistrum"])),
    "bad_part_names_language.json": ("parts[1].names.fr", lambda m: m["parts"][1]["names"].update(fr="Femur droit")),
    "bad_part_system_number.json": ("parts[4].system", lambda m: m["parts"][4].update(system=1)),
}

# Numbers beyond what the package's floats hold: valid_named_subset.json with one number that
# rounds to a float's infinity, or a matrix singular only once rounded to float (its entries
# below a float's smallest step). Both parsers name the field and say the same words (the
# "message" in expected.json).
beyond = "is beyond a float's range"
bad_numbers = {
    "bad_bounds_beyond_float.json": ("bounds.max[2]", "1e+39 " + beyond, lambda m: m["bounds"]["max"].__setitem__(2, 1e39)),
    "bad_component_bounds_beyond_float.json": ("components[0].bounds.min[0]", "-1e+39 " + beyond, lambda m: m["components"][0]["bounds"]["min"].__setitem__(0, -1e39)),
    "bad_component_error_bound_beyond_float.json": ("components[3].error_bound", "1e+39 " + beyond, lambda m: m["components"][3].update(error_bound=1e39)),
    "bad_instance_matrix_beyond_float.json": ("instances[2].matrix[13]", "-1e+39 " + beyond, lambda m: m["instances"][2]["matrix"].__setitem__(13, -1e39)),
    "bad_instance_error_bound_beyond_float.json": ("instances[1].error_bound", "3.5e+38 " + beyond, lambda m: m["instances"][1].update(error_bound=3.5e38)),
    "bad_instance_matrix_singular_in_float.json": ("instances[4].matrix", "singular (determinant 0)", lambda m: m["instances"][4].update(matrix=[1e-50, 0, 0, 0, 0, 1e-50, 0, 0, 0, 0, 1e-50, 0, 0, 0, 0, 1])),
}

expected = {}
for name in sorted(f for f in os.listdir(here) if f.startswith("valid_") and f.endswith(".json")):
    m = load(name)
    expected[name] = {key: len(m[key]) for key in ("parts", "components", "instances", "chunks")}
for name, (path, edit) in bad.items():
    m = json.loads(json.dumps(base))
    edit(m)
    dump(name, m)
    expected[name] = {"error": path}
for name, (path, edit) in bad_levels.items():
    m = json.loads(json.dumps(levels_base))
    edit(m)
    dump(name, m)
    expected[name] = {"error": path}
for name, (path, edit) in bad_regions.items():
    m = json.loads(json.dumps(regions_base))
    edit(m)
    dump(name, m)
    expected[name] = {"error": path}
for name, (path, message, edit) in bad_numbers.items():
    m = json.loads(json.dumps(base))
    edit(m)
    dump(name, m)
    expected[name] = {"error": path, "message": message}
with open(os.path.join(here, "expected.json"), "w", encoding="utf-8") as f:
    json.dump(dict(sorted(expected.items())), f, indent=2)
    f.write("\n")
