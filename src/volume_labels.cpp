// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "volume_internal.hpp"

// Based on: the Caret/Connectome Workbench label table as TotalSegmentator writes it into a NIfTI
// extension of code 0 (nifti_ext_header.py: <CaretExtension> ... <LabelTable> <Label Key="1"
// Red="0.0" Green="1.0" Blue="0.0" Alpha="1"><![CDATA[spleen]]></Label> ...), read by a small
// scanner that knows elements, attributes, CDATA sections, comments and the XML 1.0 entities,
// nothing more; and 3D Slicer's segmentation keys in a .seg.nrrd (vtkMRMLSegmentationStorageNode:
// SegmentN_ID, _Name, _Color, _LabelValue, _Layer).

namespace osteon::detail {

namespace {

void append_utf8(uint32_t code, std::string* out) {
  if (code < 0x80) {
    out->push_back(static_cast<char>(code));
  } else if (code < 0x800) {
    out->push_back(static_cast<char>(0xc0 | code >> 6));
    out->push_back(static_cast<char>(0x80 | (code & 0x3f)));
  } else if (code < 0x10000) {
    out->push_back(static_cast<char>(0xe0 | code >> 12));
    out->push_back(static_cast<char>(0x80 | (code >> 6 & 0x3f)));
    out->push_back(static_cast<char>(0x80 | (code & 0x3f)));
  } else {
    out->push_back(static_cast<char>(0xf0 | code >> 18));
    out->push_back(static_cast<char>(0x80 | (code >> 12 & 0x3f)));
    out->push_back(static_cast<char>(0x80 | (code >> 6 & 0x3f)));
    out->push_back(static_cast<char>(0x80 | (code & 0x3f)));
  }
}

// Appends `text` with &amp; &lt; &gt; &quot; &apos; and &#N; / &#xH; decoded; anything else after
// an '&' is kept as it is.
void append_decoded(std::string_view text, std::string* out) {
  static const std::pair<std::string_view, char> kEntities[] = {
      {"amp;", '&'}, {"lt;", '<'}, {"gt;", '>'}, {"quot;", '"'}, {"apos;", '\''}};
  for (size_t i = 0; i < text.size();) {
    if (text[i] != '&') {
      out->push_back(text[i++]);
      continue;
    }
    std::string_view rest = text.substr(i + 1);
    bool decoded = false;
    for (const auto& [name, c] : kEntities) {
      if (rest.starts_with(name)) {
        out->push_back(c);
        i += 1 + name.size();
        decoded = true;
        break;
      }
    }
    if (!decoded && rest.starts_with('#')) {
      const bool hex = rest.size() > 1 && (rest[1] == 'x' || rest[1] == 'X');
      const size_t digits = hex ? 2 : 1;
      const size_t semicolon = rest.find(';');
      uint32_t code = 0;
      if (semicolon != std::string_view::npos && semicolon > digits) {
        const char* first = rest.data() + digits;
        const char* last = rest.data() + semicolon;
        auto [ptr, ec] = std::from_chars(first, last, code, hex ? 16 : 10);
        if (ec == std::errc() && ptr == last && code > 0 && code <= 0x10ffff &&
            (code < 0xd800 || code > 0xdfff)) {
          append_utf8(code, out);
          i += 1 + semicolon + 1;
          decoded = true;
        }
      }
    }
    if (!decoded) out->push_back(text[i++]);
  }
}

bool parse_uint32(std::string_view text, uint32_t* out) {
  text = trim(text);
  if (text.empty()) return false;
  auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), *out);
  return ec == std::errc() && ptr == text.data() + text.size();
}

bool parse_unit_float(std::string_view text, float* out) {
  text = trim(text);
  if (text.empty() || text.size() > 64) return false;
  std::string copy(text);
  char* end = nullptr;
  double v = std::strtod(copy.c_str(), &end);
  if (end != copy.c_str() + copy.size() || !(v >= 0 && v <= 1)) return false;
  *out = static_cast<float>(v);
  return true;
}

// One <Label ...>name</Label> of a Caret label table.
struct CaretLabel {
  std::map<std::string, std::string> attributes;
  std::string name;
};

class CaretScanner {
 public:
  CaretScanner(std::string_view xml, const std::string& source, const std::string& field)
      : xml_(xml), source_(source), field_(field) {}

  Result<std::vector<VolumeLabel>> run() {
    size_t open = find_tag("<LabelTable", 0);
    if (open == std::string_view::npos) return std::vector<VolumeLabel>{};
    size_t pos = xml_.find('>', open);
    if (pos == std::string_view::npos) return bad("an unterminated <LabelTable> tag", open);
    if (xml_[pos - 1] == '/') return std::vector<VolumeLabel>{};  // <LabelTable/>
    ++pos;
    std::vector<VolumeLabel> labels;
    std::vector<std::string> fields;
    std::set<uint32_t> keys;
    for (;;) {
      pos = xml_.find('<', pos);
      if (pos == std::string_view::npos) return bad("a <LabelTable> without </LabelTable>", open);
      std::string_view rest = xml_.substr(pos);
      if (rest.starts_with("</LabelTable")) break;
      if (rest.starts_with("<!--")) {
        size_t end = xml_.find("-->", pos + 4);
        if (end == std::string_view::npos) return bad("an unterminated comment", pos);
        pos = end + 3;
        continue;
      }
      if (find_tag("<Label", pos) != pos) {
        size_t end = xml_.find('>', pos);
        if (end == std::string_view::npos) return bad("an unterminated tag", pos);
        pos = end + 1;
        continue;
      }
      const size_t at = pos;
      CaretLabel label;
      OSTEON_RETURN_IF_ERROR(parse_label(&pos, &label));
      auto key = label.attributes.find("Key");
      uint32_t value = 0;
      if (key == label.attributes.end()) return bad("a <Label> without a Key", at);
      if (!parse_uint32(key->second, &value)) {
        return bad("<Label Key=" + in_quotes(key->second) +
                       ">: the Key is not an integer of 0 to 2^32 - 1",
                   at);
      }
      if (!keys.insert(value).second) {
        return bad("Key " + std::to_string(value) + " has two <Label> entries", at);
      }
      if (value == 0) continue;  // the background ("???" in Workbench's tables)
      VolumeLabel entry;
      entry.value = value;
      entry.name = std::string(trim(label.name));
      static const char* const kChannels[3] = {"Red", "Green", "Blue"};
      float rgb[3] = {0, 0, 0};
      int channels = 0;
      for (int c = 0; c < 3; ++c) {
        auto it = label.attributes.find(kChannels[c]);
        if (it == label.attributes.end()) continue;
        if (!parse_unit_float(it->second, &rgb[c])) {
          return bad("<Label Key=\"" + std::to_string(value) + "\"> " + kChannels[c] + "=" +
                         in_quotes(it->second) + " is not a number of 0 to 1",
                     at);
        }
        ++channels;
      }
      if (channels == 3) {
        entry.has_color = true;
        entry.color = Vec3{rgb[0], rgb[1], rgb[2]};
      }
      labels.push_back(std::move(entry));
      fields.push_back(field_ + ", <Label Key=\"" + std::to_string(value) + "\">");
    }
    OSTEON_RETURN_IF_ERROR(check_unique_names(labels, fields, source_));
    std::vector<size_t> order(labels.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(),
              [&](size_t a, size_t b) { return labels[a].value < labels[b].value; });
    std::vector<VolumeLabel> sorted;
    sorted.reserve(labels.size());
    for (size_t i : order) sorted.push_back(std::move(labels[i]));
    return sorted;
  }

 private:
  Status bad(const std::string& what, size_t at) const {
    return error(ErrorCode::kInvalidData, source_, "label table: " + what,
                 field_ + ", byte " + std::to_string(at));
  }

  // The position of the element `tag` ("<Label") at or after `from`, not a longer name.
  size_t find_tag(std::string_view tag, size_t from) const {
    for (size_t at = xml_.find(tag, from); at != std::string_view::npos;
         at = xml_.find(tag, at + 1)) {
      const size_t next = at + tag.size();
      if (next < xml_.size() && (is_space(xml_[next]) || xml_[next] == '>' || xml_[next] == '/')) {
        return at;
      }
    }
    return std::string_view::npos;
  }

  // At "<Label": its attributes, then its content up to </Label>.
  Status parse_label(size_t* pos, CaretLabel* label) {
    const size_t start = *pos;
    size_t p = start + 6;
    for (;;) {
      while (p < xml_.size() && is_space(xml_[p])) ++p;
      if (p >= xml_.size()) return bad("an unterminated <Label> tag", start);
      if (xml_[p] == '>') {
        ++p;
        break;
      }
      if (xml_.substr(p).starts_with("/>")) {
        *pos = p + 2;
        return {};
      }
      const size_t name_begin = p;
      while (p < xml_.size() && !is_space(xml_[p]) && xml_[p] != '=' && xml_[p] != '>' &&
             xml_[p] != '/') {
        ++p;
      }
      std::string name(xml_.substr(name_begin, p - name_begin));
      while (p < xml_.size() && is_space(xml_[p])) ++p;
      if (name.empty() || p >= xml_.size() || xml_[p] != '=') {
        return bad("a malformed attribute in a <Label> tag", name_begin);
      }
      ++p;
      while (p < xml_.size() && is_space(xml_[p])) ++p;
      if (p >= xml_.size() || (xml_[p] != '"' && xml_[p] != '\'')) {
        return bad("an unquoted attribute value in a <Label> tag", p);
      }
      const char quote = xml_[p++];
      const size_t end = xml_.find(quote, p);
      if (end == std::string_view::npos) return bad("an unterminated attribute value", p);
      std::string value;
      append_decoded(xml_.substr(p, end - p), &value);
      label->attributes.emplace(std::move(name), std::move(value));
      p = end + 1;
    }
    // The content: text and CDATA sections up to </Label>.
    for (;;) {
      const size_t lt = xml_.find('<', p);
      if (lt == std::string_view::npos) return bad("a <Label> without </Label>", start);
      append_decoded(xml_.substr(p, lt - p), &label->name);
      std::string_view rest = xml_.substr(lt);
      if (rest.starts_with("</Label>")) {
        *pos = lt + 8;
        return {};
      }
      if (rest.starts_with("</LabelTable")) return bad("a <Label> without </Label>", start);
      if (rest.starts_with("<![CDATA[")) {
        const size_t end = xml_.find("]]>", lt + 9);
        if (end == std::string_view::npos) return bad("an unterminated CDATA section", lt);
        label->name.append(xml_.substr(lt + 9, end - lt - 9));
        p = end + 3;
        continue;
      }
      if (rest.starts_with("<!--")) {
        const size_t end = xml_.find("-->", lt + 4);
        if (end == std::string_view::npos) return bad("an unterminated comment", lt);
        p = end + 3;
        continue;
      }
      return bad("an element inside a <Label>", lt);
    }
  }

  std::string_view xml_;
  const std::string& source_;
  const std::string& field_;
};

}  // namespace

Status check_unique_names(const std::vector<VolumeLabel>& labels,
                          const std::vector<std::string>& fields, const std::string& source) {
  std::unordered_map<std::string, size_t> seen;
  for (size_t i = 0; i < labels.size(); ++i) {
    if (labels[i].name.empty()) continue;
    auto [it, inserted] = seen.emplace(labels[i].name, i);
    if (!inserted) {
      return error(ErrorCode::kInvalidData, source,
                   "label table gives labels " + std::to_string(labels[it->second].value) +
                       " and " + std::to_string(labels[i].value) + " one name, " +
                       in_quotes(labels[i].name),
                   fields[i]);
    }
  }
  return {};
}

Result<std::vector<VolumeLabel>> parse_caret_label_table(std::string_view xml,
                                                         const std::string& source,
                                                         const std::string& field) {
  CaretScanner scanner(xml, source, field);
  return scanner.run();
}

Result<std::vector<SlicerSegment>> parse_slicer_segments(
    const std::vector<std::pair<std::string, std::string>>& key_values, uint32_t layers,
    const std::string& source) {
  struct Keys {
    std::map<std::string, std::string> fields;  // "Name" -> value
  };
  std::map<uint32_t, Keys> by_index;
  for (const auto& [key, value] : key_values) {
    if (!key.starts_with("Segment") || key.size() < 9) continue;
    size_t p = 7;
    while (p < key.size() && key[p] >= '0' && key[p] <= '9') ++p;
    if (p == 7 || p >= key.size() || key[p] != '_') continue;  // Segmentation_... keys
    uint32_t index = 0;
    if (!parse_uint32(std::string_view(key).substr(7, p - 7), &index)) {
      return error(ErrorCode::kInvalidData, source, "a segment number that is not an integer", key);
    }
    by_index[index].fields[key.substr(p + 1)] = value;
  }

  std::vector<SlicerSegment> segments;
  std::vector<VolumeLabel> labels;
  std::vector<std::string> name_fields;
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> taken;  // (layer, value) -> segment index
  uint32_t ordinal = 0;
  // No structured binding here: clang 14's lambdas cannot capture one.
  for (const auto& entry : by_index) {
    const uint32_t index = entry.first;
    const Keys& keys = entry.second;
    const std::string prefix = "Segment" + std::to_string(index) + "_";
    auto get = [&](const char* name) -> const std::string* {
      auto it = keys.fields.find(name);
      return it == keys.fields.end() ? nullptr : &it->second;
    };
    SlicerSegment segment;
    segment.index = static_cast<int>(index);
    segment.label.value = 1;
    // Slicer before layers (4.10): one segment a layer, each of value 1.
    segment.layer = layers > 1 ? ordinal : 0;
    ++ordinal;
    if (const std::string* name = get("Name")) {
      segment.label.name = std::string(trim(*name));
    } else if (const std::string* id = get("ID")) {
      segment.label.name = std::string(trim(*id));
    }
    if (const std::string* text = get("LabelValue")) {
      if (!parse_uint32(*text, &segment.label.value) || segment.label.value == 0) {
        return error(ErrorCode::kInvalidData, source,
                     "label value " + in_quotes(*text) + " is not an integer of 1 to 2^32 - 1",
                     prefix + "LabelValue");
      }
    }
    if (const std::string* text = get("Layer")) {
      if (!parse_uint32(*text, &segment.layer)) {
        return error(ErrorCode::kInvalidData, source,
                     "layer " + in_quotes(*text) + " is not a non-negative integer",
                     prefix + "Layer");
      }
    }
    if (segment.layer >= layers) {
      return error(ErrorCode::kInvalidData, source,
                   "layer " + std::to_string(segment.layer) + ", but the file holds " +
                       std::to_string(layers) + (layers == 1 ? " layer" : " layers"),
                   prefix + "Layer");
    }
    if (const std::string* text = get("Color")) {
      std::string_view rest = trim(*text);
      float rgb[3] = {0, 0, 0};
      for (int c = 0; c < 3; ++c) {
        size_t end = 0;
        while (end < rest.size() && !is_space(rest[end])) ++end;
        if (!parse_unit_float(rest.substr(0, end), &rgb[c])) {
          return error(ErrorCode::kInvalidData, source,
                       "colour " + in_quotes(*text) + " is not three numbers of 0 to 1",
                       prefix + "Color");
        }
        rest = trim(rest.substr(end));
      }
      if (!rest.empty()) {
        return error(ErrorCode::kInvalidData, source,
                     "colour " + in_quotes(*text) + " is not three numbers of 0 to 1",
                     prefix + "Color");
      }
      segment.label.has_color = true;
      segment.label.color = Vec3{rgb[0], rgb[1], rgb[2]};
    }
    auto [it, inserted] = taken.emplace(std::make_pair(segment.layer, segment.label.value), index);
    if (!inserted) {
      return error(ErrorCode::kInvalidData, source,
                   "segments " + std::to_string(it->second) + " and " + std::to_string(index) +
                       " both have label value " + std::to_string(segment.label.value) +
                       " in layer " + std::to_string(segment.layer),
                   prefix + "LabelValue");
    }
    labels.push_back(segment.label);
    name_fields.push_back(prefix + "Name");
    segments.push_back(std::move(segment));
  }
  OSTEON_RETURN_IF_ERROR(check_unique_names(labels, name_fields, source));
  return segments;
}

}  // namespace osteon::detail
