#include "render/mesh_text.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <system_error>

#include <nlohmann/json.hpp>

#include "core/fsutil.h"

namespace dg::meshtext {

bool parseDouble(std::string_view tok, double& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  if (ptr != tok.data() + tok.size()) return false;
  if (ec == std::errc::result_out_of_range) {
    out = std::strtod(std::string(tok).c_str(), nullptr);
    return true;
  }
  return ec == std::errc();
}

bool parseLong(std::string_view tok, long& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return ec == std::errc() && ptr == tok.data() + tok.size();
}

std::vector<Token> tokenize(std::string_view line) {
  std::vector<Token> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) out.push_back({line.substr(start, i - start), int(start) + 1});
  }
  return out;
}

namespace {

struct Tok {
  std::string text;
  int column;
};
// A line with at least one token.
struct DataLine {
  int number;
  std::vector<Tok> tok;
  int end;  // the column just past its last character
};

// The file's lines that hold tokens, with '\r' removed and, if `comment` is not 0, everything from
// that character on.
std::vector<DataLine> dataLines(const std::string& path, char comment) {
  std::vector<DataLine> out;
  std::ifstream in(path, std::ios::binary);
  std::string s;
  for (int n = 1; std::getline(in, s); ++n) {
    if (!s.empty() && s.back() == '\r') s.pop_back();
    if (comment != 0) {
      const size_t c = s.find(comment);
      if (c != std::string::npos) s.resize(c);
    }
    DataLine l{n, {}, 0};
    for (const Token& t : tokenize(s)) {
      l.tok.push_back({std::string(t.text), t.column});
      l.end = t.column + int(t.text.size());
    }
    if (!l.tok.empty()) out.push_back(std::move(l));
  }
  return out;
}

// A token as a message shows it: quoted, at most 40 characters, bytes that do not print as '?'.
std::string quoted(const std::string& s) {
  std::string q = "'";
  for (size_t i = 0; i < s.size() && i < 40; ++i) q += (s[i] >= 32 && s[i] < 127) ? s[i] : '?';
  return q + (s.size() > 40 ? "...'" : "'");
}

// A little-endian 32-bit count (STL's facet count, GLB's header and chunk lengths).
uintmax_t le32(const unsigned char* p) {
  return uintmax_t(p[0]) | uintmax_t(p[1]) << 8 | uintmax_t(p[2]) << 16 | uintmax_t(p[3]) << 24;
}

FileProblem at(const DataLine& l, const Tok& t, const std::string& what) { return {l.number, t.column, what}; }
FileProblem pastEnd(const DataLine& l, const std::string& what) { return {l.number, l.end, what}; }

bool finiteNumber(const std::string& s) {
  double v;
  return parseDouble(s, v) && std::isfinite(v);
}

// Checks that tokens [from, from + count) of line l are finite numbers; `what` names them.
std::optional<FileProblem> numbers(const DataLine& l, size_t from, size_t count, const std::string& what) {
  for (size_t k = from; k < from + count; ++k) {
    if (k >= l.tok.size())
      return pastEnd(l, what + ": expected " + std::to_string(count) + " numbers, found " + std::to_string(k - from));
    if (!finiteNumber(l.tok[k].text))
      return at(l, l.tok[k], what + ": expected a finite number, found " + quoted(l.tok[k].text));
  }
  return std::nullopt;
}

// A face's corner indices: tokens [from, from + count) of line l, each an integer in [0, nv).
std::optional<FileProblem> indices(const DataLine& l, size_t from, long count, long nv, const std::string& what) {
  for (long k = 0; k < count; ++k) {
    const size_t i = from + size_t(k);
    if (i >= l.tok.size())
      return pastEnd(l, what + ": expected " + std::to_string(count) + " vertex indices, found " + std::to_string(k));
    long v;
    if (!parseLong(l.tok[i].text, v) || v < 0 || v >= nv)
      return at(l, l.tok[i], what + ": expected a vertex index from 0 to " + std::to_string(nv - 1) + ", found " +
                                 quoted(l.tok[i].text));
  }
  return std::nullopt;
}

// PLY's scalar types, with the sized aliases: bytes, signed, integer.
struct PlyType {
  int size;
  bool is_signed, integer;
};
const PlyType* plyType(std::string_view name) {
  static const std::map<std::string, PlyType, std::less<>> kTypes = {
      {"char", {1, true, true}},    {"uchar", {1, false, true}},  {"short", {2, true, true}},
      {"ushort", {2, false, true}}, {"int", {4, true, true}},      {"uint", {4, false, true}},
      {"int8", {1, true, true}},    {"uint8", {1, false, true}},  {"int16", {2, true, true}},
      {"uint16", {2, false, true}}, {"int32", {4, true, true}},   {"uint32", {4, false, true}},
      {"float", {4, true, false}},  {"double", {8, true, false}}, {"float32", {4, true, false}},
      {"float64", {8, true, false}}};
  const auto it = kTypes.find(name);
  return it == kTypes.end() ? nullptr : &it->second;
}

// A PLY value against its property's type: a float that a float holds, an integer in its range.
std::optional<FileProblem> typed(const DataLine& l, const Tok& t, const std::string& type, const std::string& what) {
  double v;
  const PlyType* pt = plyType(type);
  if (pt && pt->integer) {
    const int bits = 8 * pt->size;
    const double lo = pt->is_signed ? -std::ldexp(1.0, bits - 1) : 0.0;
    const double hi = std::ldexp(1.0, pt->is_signed ? bits - 1 : bits) - 1.0;
    long n;
    if (!parseLong(t.text, n) || double(n) < lo || double(n) > hi)
      return at(l, t, what + ": expected an integer that a " + type + " holds, found " + quoted(t.text));
    return std::nullopt;
  }
  const double limit = type == "float" || type == "float32" ? double(std::numeric_limits<float>::max())
                                                            : std::numeric_limits<double>::max();
  if (!parseDouble(t.text, v) || !(std::fabs(v) <= limit))
    return at(l, t, what + ": expected a number that a " + type + " holds, found " + quoted(t.text));
  return std::nullopt;
}

// The prefixes of an OFF keyword ending in "OFF": [ST][C][N] in any order (normals, vertex
// colours, texture coordinates); nullopt for any other letter (4OFF, nOFF, or not a keyword).
struct OffPrefixes {
  bool normals = false, colours = false, texcoords = false;
};
std::optional<OffPrefixes> offPrefixes(std::string_view kw) {
  OffPrefixes f;
  for (size_t i = 0; i + 3 < kw.size();) {
    if (kw.substr(i, 2) == "ST") {
      f.texcoords = true;
      i += 2;
    } else if (kw[i] == 'C' || kw[i] == 'N') {
      (kw[i] == 'C' ? f.colours : f.normals) = true;
      ++i;
    } else {
      return std::nullopt;
    }
  }
  return f;
}

}  // namespace

std::optional<FileProblem> findNonFinite(const std::string& path) {
  for (const DataLine& l : dataLines(path, 0))
    for (const Tok& t : l.tok) {
      double v;
      if (parseDouble(t.text, v) && !std::isfinite(v)) return at(l, t, "non-finite coordinate (" + t.text + ")");
    }
  return std::nullopt;
}

std::optional<FileProblem> diagnoseOff(const std::string& path) {
  const std::vector<DataLine> lines = dataLines(path, '#');
  if (lines.empty()) return FileProblem{0, 0, "the file is empty; expected the OFF header"};
  const DataLine& head = lines[0];
  const std::string& kw = head.tok[0].text;
  if (kw.size() < 3 || kw.compare(kw.size() - 3, 3, "OFF") != 0)
    return at(head, head.tok[0], "expected the header keyword OFF (or COFF, NOFF, STOFF, ...), found " + quoted(kw));
  const std::optional<OffPrefixes> prefixes = offPrefixes(kw);
  if (!prefixes) return std::nullopt;  // 4OFF, nOFF: not looked into
  const auto [normals, colours, texcoords] = *prefixes;
  // The counts follow the keyword, on its line or the next.
  size_t li = 0, ti = 1;
  if (head.tok.size() == 1) li = 1, ti = 0;
  if (li >= lines.size()) return pastEnd(head, "the file ends after the header; expected the vertex and face counts");
  const DataLine& cl = lines[li];
  if (cl.tok[ti].text == "BINARY") return std::nullopt;
  long nv = -1, nf = -1;
  for (long* c : {&nv, &nf}) {
    if (ti >= cl.tok.size()) return pastEnd(cl, "expected the vertex and face counts, found one number");
    if (!parseLong(cl.tok[ti].text, *c) || *c < 0)
      return at(cl, cl.tok[ti], std::string("expected the ") + (c == &nv ? "vertex" : "face") +
                                    " count (an integer >= 0), found " + quoted(cl.tok[ti].text));
    ++ti;
  }
  long ne;  // the edge count, which CGAL reads (as an int) and ignores
  if (ti >= cl.tok.size()) return pastEnd(cl, "expected the edge count after the vertex and face counts (0 will do)");
  if (!parseLong(cl.tok[ti].text, ne) || ne < 0 || ne > 2147483647L)
    return at(cl, cl.tok[ti], "expected the edge count (an integer from 0 to 2147483647; 0 will do), found " + quoted(cl.tok[ti].text));
  const size_t per_vertex = 3 + (normals ? 3 : 0) + (colours ? 1 : 0) + (texcoords ? 2 : 0);
  size_t next = li + 1;
  for (long v = 0; v < nv; ++v, ++next) {
    if (next >= lines.size())
      return pastEnd(lines.back(), "the file ends after " + std::to_string(v) + " of the " + std::to_string(nv) +
                                       " vertices the header declares");
    const DataLine& l = lines[next];
    if (auto p = numbers(l, 0, std::max(per_vertex, l.tok.size()), "vertex " + std::to_string(v) + " (counting from 0)")) return p;
  }
  for (long f = 0; f < nf; ++f, ++next) {
    if (next >= lines.size())
      return pastEnd(lines.back(), "the file ends after " + std::to_string(f) + " of the " + std::to_string(nf) +
                                       " faces the header declares");
    const DataLine& l = lines[next];
    const std::string what = "face " + std::to_string(f) + " (counting from 0)";
    long k;
    if (!parseLong(l.tok[0].text, k) || k < 3) {
      double x;
      const bool coordinate = parseDouble(l.tok[0].text, x) && x != std::floor(x);
      return at(l, l.tok[0], what + ": expected its number of corners (an integer >= 3), found " + quoted(l.tok[0].text) +
                                 (coordinate ? " (more vertex lines than the header's " + std::to_string(nv) + "?)" : ""));
    }
    if (auto p = indices(l, 1, k, nv, what)) return p;
    if (auto p = numbers(l, 1 + size_t(k), l.tok.size() - 1 - size_t(k), what + " colour")) return p;
  }
  return std::nullopt;
}

std::optional<FileProblem> diagnoseStl(const std::string& path) {
  std::error_code ec;
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return std::nullopt;
  const std::vector<DataLine> lines = dataLines(path, 0);
  if (lines.empty() || lines[0].tok[0].text != "solid") {
    if (size == 0) return FileProblem{0, 0, "the file is empty"};
    if (size < 84) return FileProblem{0, 0, "neither an ASCII STL (which starts with 'solid') nor a binary one (84 bytes of header and count, the file has " + std::to_string(size) + ")"};
    unsigned char c[4];
    std::ifstream in(path, std::ios::binary);
    in.seekg(80);
    in.read(reinterpret_cast<char*>(c), 4);
    const uintmax_t n = le32(c);
    if (size != 84 + 50 * n)
      return FileProblem{0, 0, "a binary STL declaring " + std::to_string(n) + " facets is " + std::to_string(84 + 50 * n) +
                                   " bytes long, the file has " + std::to_string(size) + " (truncated, or not an STL file)"};
    return std::nullopt;
  }
  // ASCII: solid [name] { facet normal n n n  outer loop  vertex x y z (x3)  endloop  endfacet } endsolid
  // The name is the rest of the first line.
  size_t li = 1, ti = 0;
  auto done = [&] { return li >= lines.size(); };
  auto tok = [&]() -> const Tok& { return lines[li].tok[ti]; };
  auto advance = [&] {
    if (++ti >= lines[li].tok.size()) ++li, ti = 0;
  };
  long facet = 0;
  auto expect = [&](const std::string& word, const std::string& where) -> std::optional<FileProblem> {
    if (done()) return pastEnd(lines.back(), "the file ends " + where + "; expected '" + word + "'");
    if (tok().text != word)
      return at(lines[li], tok(), "expected '" + word + "' " + where + ", found " + quoted(tok().text));
    advance();
    return std::nullopt;
  };
  auto number = [&](const std::string& what) -> std::optional<FileProblem> {
    if (done()) return pastEnd(lines.back(), "the file ends in " + what + "; expected a number");
    if (!finiteNumber(tok().text)) return at(lines[li], tok(), what + ": expected a finite number, found " + quoted(tok().text));
    advance();
    return std::nullopt;
  };
  while (true) {
    if (done()) return pastEnd(lines.back(), "the file ends after " + std::to_string(facet) + " facets; expected 'endsolid'");
    if (tok().text == "endsolid") return std::nullopt;
    const std::string in = "in facet " + std::to_string(facet) + " (counting from 0)";
    if (auto p = expect("facet", "or 'endsolid' after facet " + std::to_string(facet))) return p;
    if (auto p = expect("normal", in)) return p;
    for (int k = 0; k < 3; ++k)
      if (auto p = number("the normal " + in)) return p;
    if (auto p = expect("outer", in)) return p;
    if (auto p = expect("loop", in)) return p;
    for (int c = 0; c < 3; ++c) {
      if (auto p = expect("vertex", in)) return p;
      for (int k = 0; k < 3; ++k)
        if (auto p = number("vertex " + std::to_string(c) + " " + in)) return p;
    }
    if (auto p = expect("endloop", in)) return p;
    if (auto p = expect("endfacet", in)) return p;
    ++facet;
  }
}

std::optional<FileProblem> diagnosePly(const std::string& path) {
  const std::vector<DataLine> lines = dataLines(path, 0);
  if (lines.empty()) return FileProblem{0, 0, "the file is empty; expected the PLY header"};
  if (lines[0].tok[0].text != "ply" || lines[0].tok.size() != 1)
    return at(lines[0], lines[0].tok[0], "expected 'ply' alone on the first line, found " + quoted(lines[0].tok[0].text));
  struct Property {
    std::string name;
    bool list = false;
    std::string type;  // a scalar's type, or a list's item type
  };
  struct Element {
    std::string name;
    long count = 0;
    std::vector<Property> props;
  };
  std::vector<Element> elements;
  bool ascii = false, format = false;
  size_t li = 1;
  for (;; ++li) {
    if (li >= lines.size()) return pastEnd(lines.back(), "the file ends in the header; expected 'end_header'");
    const DataLine& l = lines[li];
    const std::string& w = l.tok[0].text;
    if (w == "end_header") break;
    if (w == "comment" || w == "obj_info") continue;
    if (w == "format") {
      if (l.tok.size() != 3 || (l.tok[1].text != "ascii" && l.tok[1].text != "binary_little_endian" &&
                                l.tok[1].text != "binary_big_endian"))
        return at(l, l.tok[0], "expected 'format ascii 1.0' (or binary_little_endian, binary_big_endian)");
      ascii = l.tok[1].text == "ascii";
      format = true;
    } else if (w == "element") {
      long n;
      if (l.tok.size() != 3 || !parseLong(l.tok[2].text, n) || n < 0)
        return at(l, l.tok[0], "expected 'element NAME COUNT' with a count >= 0");
      elements.push_back({l.tok[1].text, n, {}});
    } else if (w == "property") {
      if (elements.empty()) return at(l, l.tok[0], "a property before any 'element'");
      const bool list = l.tok.size() >= 2 && l.tok[1].text == "list";
      const size_t want = list ? 5 : 3;
      if (l.tok.size() != want) return at(l, l.tok[0], list ? "expected 'property list COUNT_TYPE INDEX_TYPE NAME'" : "expected 'property TYPE NAME'");
      for (size_t k = list ? 2 : 1; k + 1 < want; ++k)
        if (!plyType(l.tok[k].text))
          return at(l, l.tok[k], "expected a PLY type (char, uchar, short, ushort, int, uint, float, double, ...), found " + quoted(l.tok[k].text));
      elements.back().props.push_back({l.tok[want - 1].text, list, l.tok[want - 2].text});
    } else {
      return at(l, l.tok[0], "expected a header line (format, element, property, comment or end_header), found " + quoted(w));
    }
  }
  if (!format) return at(lines[li], lines[li].tok[0], "the header has no 'format' line");
  if (!ascii) return std::nullopt;
  long nvertex = 0;
  for (const Element& e : elements)
    if (e.name == "vertex") nvertex = e.count;
  size_t next = li + 1;
  for (const Element& e : elements)
    for (long r = 0; r < e.count; ++r, ++next) {
      if (next >= lines.size())
        return pastEnd(lines.back(), "the file ends after " + std::to_string(r) + " of the " + std::to_string(e.count) +
                                         " '" + e.name + "' lines the header declares");
      const DataLine& l = lines[next];
      const std::string what = e.name + " " + std::to_string(r) + " (counting from 0)";
      size_t t = 0;
      for (const Property& p : e.props) {
        if (t >= l.tok.size()) return pastEnd(l, what + ": expected a value for '" + p.name + "'");
        if (!p.list) {
          if (auto q = typed(l, l.tok[t], p.type, what + ": '" + p.name + "'")) return q;
          ++t;
          continue;
        }
        long k;
        if (!parseLong(l.tok[t].text, k) || k < 0)
          return at(l, l.tok[t], what + ": expected the length of '" + p.name + "' (an integer >= 0), found " + quoted(l.tok[t].text));
        ++t;
        const bool corners = e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index");
        if (corners && k < 3) return at(l, l.tok[t - 1], what + ": expected at least 3 corners, found " + std::to_string(k));
        if (corners) {
          if (auto q = indices(l, t, k, nvertex, what)) return q;
        } else {
          for (size_t i = t; i < t + size_t(k); ++i) {
            if (i >= l.tok.size()) return pastEnd(l, what + ": expected " + std::to_string(k) + " values for '" + p.name + "'");
            if (auto q = typed(l, l.tok[i], p.type, what + ": '" + p.name + "'")) return q;
          }
        }
        t += size_t(k);
      }
      if (t < l.tok.size())
        return at(l, l.tok[t], what + ": " + std::to_string(l.tok.size() - t) + " value(s) more than the header's properties");
    }
  return std::nullopt;
}

std::optional<FileProblem> diagnoseGlb(const std::string& path) {
  std::error_code ec;
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return std::nullopt;
  unsigned char h[20] = {};
  std::ifstream in(path, std::ios::binary);
  in.read(reinterpret_cast<char*>(h), 20);
  auto u32 = [&](int at) { return le32(h + at); };
  if (size < 12) return FileProblem{0, 0, "a binary glTF starts with a 12-byte header; the file has " + std::to_string(size) + " bytes"};
  if (std::memcmp(h, "glTF", 4) != 0) return FileProblem{0, 0, "not a binary glTF: the file does not start with 'glTF'"};
  if (u32(4) != 2) return FileProblem{0, 0, "binary glTF version " + std::to_string(u32(4)) + "; expected 2"};
  if (u32(8) != size)
    return FileProblem{0, 0, "the header declares " + std::to_string(u32(8)) + " bytes, the file has " + std::to_string(size) +
                                 " (truncated?)"};
  if (size < 20) return FileProblem{0, 0, "the file ends before its first chunk; expected the JSON chunk"};
  if (std::memcmp(h + 16, "JSON", 4) != 0) return FileProblem{0, 0, "the first chunk is not the JSON chunk"};
  if (20 + u32(12) > size)
    return FileProblem{0, 0, "the JSON chunk declares " + std::to_string(u32(12)) + " bytes, more than the file holds"};
  // A binary chunk after it: an 8-byte header ('BIN' and a zero byte) and its bytes within the file.
  const uintmax_t bin = 20 + u32(12);
  if (bin < size) {
    unsigned char b[8] = {};
    in.clear();
    in.seekg(std::streamoff(bin));
    in.read(reinterpret_cast<char*>(b), 8);
    const uintmax_t n = le32(b);
    if (bin + 8 > size) return FileProblem{0, 0, "the file ends inside the header of the chunk after the JSON"};
    if (std::memcmp(b + 4, "BIN\0", 4) != 0) return FileProblem{0, 0, "the chunk after the JSON is not the binary chunk ('BIN')"};
    if (bin + 8 + n > size)
      return FileProblem{0, 0, "the binary chunk declares " + std::to_string(n) + " bytes, more than the file holds"};
  }
  return std::nullopt;
}

std::optional<FileProblem> diagnoseGltfJson(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const bool glb = text.size() >= 20 && text.compare(0, 4, "glTF") == 0;
  if (glb) {
    const auto* h = reinterpret_cast<const unsigned char*>(text.data());
    const size_t n = size_t(le32(h + 12));
    if (20 + n > text.size()) return std::nullopt;
    text = text.substr(20, n);
  }
  // Where a byte offset lies in the .gltf's text (a .glb's chunk has no lines: its byte).
  auto place = [&](size_t at, std::string why) {
    for (char& ch : why)
      if (!(ch >= 32 && ch < 127)) ch = '?';  // the bytes the parser last read, as they may be
    if (glb) return FileProblem{0, 0, "the JSON chunk, byte " + std::to_string(at) + ": " + why};
    int line = 1, col = 1;
    for (size_t i = 0; i < at && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    return FileProblem{line, col, why};
  };
  try {
    const nlohmann::json j = nlohmann::json::parse(text);
    const auto asset = j.is_object() ? j.find("asset") : j.end();
    const nlohmann::json* version = nullptr;
    if (asset != j.end() && asset->is_object() && asset->contains("version")) version = &(*asset)["version"];
    if (!version || !version->is_string() || version->get<std::string>().rfind("2.", 0) != 0)
      return FileProblem{0, 0, std::string(glb ? "the JSON chunk: " : "") + "expected \"asset\": {\"version\": \"2.0\"}" +
                                   (version ? ", found version " + version->dump() : ", found no asset version")};
  } catch (const nlohmann::json::parse_error& e) {
    // e.what(): "[json.exception.parse_error.101] parse error at line L, column C: WHY"
    std::string why = e.what();
    const size_t c = why.find(": ", why.find("parse error"));
    return place(e.byte > 0 ? size_t(e.byte - 1) : 0, "invalid JSON: " + (c == std::string::npos ? why : why.substr(c + 2)));
  } catch (const nlohmann::json::exception& e) {
    // e.g. "[json.exception.out_of_range.406] number overflow parsing '1e999'": no position given,
    // so the quoted literal is looked up in the text.
    std::string why = e.what();
    const size_t b = why.find("] ");
    why = why.substr(b == std::string::npos ? 0 : b + 2);
    const size_t q0 = why.find('\''), q1 = q0 == std::string::npos ? q0 : why.find('\'', q0 + 1);
    size_t at = 0;
    if (q1 != std::string::npos) at = text.find(why.substr(q0 + 1, q1 - q0 - 1));
    if (at == std::string::npos) at = 0;
    return place(at, "invalid JSON: " + why);
  }
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------
// Lengths that the rest of the file cannot hold (oversizedOff, oversizedPlyList)

namespace {

// Whitespace-separated tokens of a text, with their lines and columns; `comment` (0: none) hides
// the rest of a line.
class TextCursor {
 public:
  TextCursor(std::string_view text, size_t from, int line, char comment)
      : t_(text), i_(from), line_(line), line_start_(from), comment_(comment) {}
  // The next token ("" at the end), its line and column.
  std::string_view next() {
    for (;;) {
      while (i_ < t_.size() && std::isspace(static_cast<unsigned char>(t_[i_]))) newlineAt(i_++);
      if (i_ < t_.size() && comment_ != 0 && t_[i_] == comment_) {
        while (i_ < t_.size() && t_[i_] != '\n') ++i_;
        continue;
      }
      break;
    }
    const size_t b = i_;
    while (i_ < t_.size() && !std::isspace(static_cast<unsigned char>(t_[i_])) && !(comment_ != 0 && t_[i_] == comment_)) ++i_;
    tok_line_ = line_;
    tok_column_ = int(b - line_start_) + 1;
    return t_.substr(b, i_ - b);
  }
  // Skips to the start of the next line that holds a token (the rest of this one is dropped).
  void nextLine() {
    while (i_ < t_.size() && t_[i_] != '\n') ++i_;
  }
  size_t left() const { return t_.size() - i_; }
  size_t offset() const { return i_; }  // just past the last token
  int line() const { return tok_line_; }
  int column() const { return tok_column_; }

 private:
  void newlineAt(size_t k) {
    if (t_[k] == '\n') {
      ++line_;
      line_start_ = k + 1;
    }
  }
  std::string_view t_;
  size_t i_;
  int line_, tok_line_ = 0, tok_column_ = 0;
  size_t line_start_;
  char comment_;
};

// A length the rest of the file cannot hold: an ASCII entry needs a character and a separator at
// least, a binary one its size.
std::string tooLong(const std::string& what, const std::string& of, long long n, size_t left) {
  return what + ": " + of + " " + std::to_string(n) + ", more than the " + std::to_string(left) +
         " bytes left in the file can hold";
}

}  // namespace

std::optional<FileProblem> oversizedOff(const std::string& path) {
  const std::string text = readTextFile(path);
  TextCursor c(text, 0, 1, '#');
  const std::string_view kw = c.next();
  // nOFF gives the dimension first; binary OFF is readBinaryOff's.
  if (kw.size() < 3 || kw.substr(kw.size() - 3) != "OFF" || kw.find('n') != std::string_view::npos) return std::nullopt;
  long counts[3];
  int count_line = 0, count_column = 0;
  for (int k = 0; k < 3; ++k) {
    const std::string_view t = c.next();
    if (k == 0) count_line = c.line(), count_column = c.column();
    if (k == 0 && t == "BINARY") return std::nullopt;
    if (!parseLong(t, counts[k])) return std::nullopt;  // the diagnoser says what it is
    if (k < 2 && counts[k] < 0)
      return FileProblem{c.line(), c.column(), std::string("expected the ") + (k == 0 ? "vertex" : "face") +
                                                   " count (an integer >= 0), found " + quoted(std::string(t))};
    if (k == 1 && 6.0 * double(counts[0]) + 8.0 * double(counts[1]) > double(text.size()))
      return FileProblem{count_line, count_column,
                         "the header declares " + std::to_string(counts[0]) + " vertices and " + std::to_string(counts[1]) +
                             " faces, more than a " + std::to_string(text.size()) + "-byte file can hold (truncated file?)"};
  }
  if (kw.find('4') != std::string_view::npos) return std::nullopt;  // 4OFF: the counts only
  // One vertex a line, as CGAL reads them (the rest of a line may hold a colour).
  for (long v = 0; v < counts[0]; ++v) {
    c.nextLine();
    if (c.next().empty()) return std::nullopt;
  }
  for (long f = 0; f < counts[1]; ++f) {
    c.nextLine();
    const std::string_view t = c.next();
    long k;
    if (!parseLong(t, k)) return std::nullopt;  // not a count: the diagnoser says what it is
    const std::string what = "face " + std::to_string(f) + " (counting from 0)";
    if (k < 0) return FileProblem{c.line(), c.column(), what + ": expected its number of corners (an integer >= 3), found " + quoted(std::string(t))};
    if (uint64_t(k) > c.left() / 2) return FileProblem{c.line(), c.column(), tooLong(what, "a corner count of", k, c.left())};
  }
  return std::nullopt;
}

BinaryOff readBinaryOff(const std::string& path) {
  BinaryOff r;
  {
    // The header from the file's head first: an ASCII file (the usual case) is not read twice.
    const std::string head = readFileHead(path, 4096);
    TextCursor h(head, 0, 1, '#');
    const std::string_view kw = h.next();
    if (kw.size() < 3 || kw.substr(kw.size() - 3) != "OFF" || h.next() != "BINARY") return r;
  }
  r.binary = true;
  const std::string text = readTextFile(path);
  TextCursor c(text, 0, 1, '#');
  const std::string_view kw = c.next();
  const int kw_line = c.line(), kw_column = c.column();
  c.next();  // BINARY
  auto fail = [&](int line, int column, const std::string& what) {
    r.problem = FileProblem{line, column, what};
    r.mesh = OffMesh{};
    return r;
  };
  const std::optional<OffPrefixes> prefixes = offPrefixes(kw);
  if (!prefixes || prefixes->colours)
    return fail(kw_line, kw_column, "binary " + quoted(std::string(kw)) + " is not read (binary OFF, NOFF, STOFF and STNOFF "
                                    "are; vertex colours, 4OFF and nOFF only in ASCII)");
  const bool normals = prefixes->normals, texcoords = prefixes->texcoords;
  const size_t eol = text.find('\n', c.offset());
  if (eol == std::string::npos) return fail(c.line(), c.column(), "expected a newline after BINARY, then the binary data");
  const auto* b = reinterpret_cast<const unsigned char*>(text.data());
  size_t at = eol + 1;
  auto word = [&](size_t k) { return uint32_t(b[k]) << 24 | uint32_t(b[k + 1]) << 16 | uint32_t(b[k + 2]) << 8 | b[k + 3]; };
  auto left = [&] { return text.size() - at; };
  auto where = [&](const std::string& what) { return what + ", at byte " + std::to_string(at); };
  auto integer = [&] { const int32_t v = int32_t(word(at)); at += 4; return v; };
  auto real = [&] {
    const uint32_t w = word(at);
    at += 4;
    float f;
    std::memcpy(&f, &w, 4);
    return double(f);
  };
  if (left() < 12) return fail(0, 0, where("the vertex, face and edge counts") + ": expected 12 bytes, the file has " + std::to_string(left()));
  const int32_t nv = integer(), nf = integer();
  at += 4;  // the edge count, unused
  if (nv < 0 || nf < 0)
    return fail(0, 0, "the header declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) + " faces; expected counts >= 0");
  const size_t per_vertex = 4 * (3 + (normals ? 3 : 0) + (texcoords ? 2 : 0));
  // A face takes 20 bytes at least: its corner count, 3 corners and its colour count.
  if (uint64_t(nv) * per_vertex + uint64_t(nf) * 20 > left())
    return fail(0, 0, "the header declares " + std::to_string(nv) + " vertices of " + std::to_string(per_vertex) + " bytes and " +
                          std::to_string(nf) + " faces, more than the " + std::to_string(left()) +
                          " bytes after it can hold (truncated file?)");
  OffMesh& m = r.mesh;
  m.pos.resize(size_t(nv));
  if (normals) m.nrm.resize(size_t(nv));
  if (texcoords) m.uv.resize(size_t(nv));
  for (int32_t v = 0; v < nv; ++v) {
    const size_t start = at;
    double* fields[3] = {m.pos[size_t(v)].data(), normals ? m.nrm[size_t(v)].data() : nullptr,
                         texcoords ? m.uv[size_t(v)].data() : nullptr};
    for (int g = 0; g < 3; ++g)
      for (int k = 0; fields[g] && k < (g == 2 ? 2 : 3); ++k) {
        fields[g][k] = real();
        if (!std::isfinite(fields[g][k]))
          return fail(0, 0, "vertex " + std::to_string(v) + " (counting from 0), at byte " + std::to_string(start) +
                                ": expected finite numbers, found " + std::to_string(fields[g][k]));
      }
  }
  m.faces.resize(size_t(nf));
  for (int32_t f = 0; f < nf; ++f) {
    const std::string what = "face " + std::to_string(f) + " (counting from 0)";
    if (left() < 4)
      return fail(0, 0, "the file ends after " + std::to_string(f) + " of the " + std::to_string(nf) + " faces the header declares");
    const std::string head = where(what);
    const int32_t k = integer();
    if (k < 3) return fail(0, 0, head + ": expected its number of corners (an integer >= 3), found " + std::to_string(k));
    if (uint64_t(k) + 1 > left() / 4) return fail(0, 0, tooLong(head, "a corner count of", k, left()));
    std::vector<uint32_t>& face = m.faces[size_t(f)];
    face.resize(size_t(k));
    for (uint32_t& i : face) {
      const int32_t v = integer();
      if (v < 0 || v >= nv)
        return fail(0, 0, head + ": expected a vertex index from 0 to " + std::to_string(nv - 1) + ", found " + std::to_string(v));
      i = uint32_t(v);
    }
    const int32_t colours = integer();
    if (colours < 0 || colours > 4 || size_t(colours) * 4 > left())
      return fail(0, 0, head + ": expected its number of colour components (0 to 4, as many floats after it), found " +
                            std::to_string(colours) + (colours >= 0 && colours <= 4 ? " with " + std::to_string(left()) + " bytes left" : ""));
    at += size_t(colours) * 4;
  }
  return r;
}

std::optional<FileProblem> oversizedPlyList(const std::string& path) {
  const std::string text = readTextFile(path);
  // The header, line by line up to 'end_header' (as CGAL reads it).
  struct Property {
    std::string name;
    int count_size = 0;  // a list's length type in bytes (0: a scalar)
    bool count_signed = false;
    int size = 0;        // the scalar's, or a list entry's, size in bytes
  };
  struct Element {
    std::string name;
    long count = 0;
    std::vector<Property> props;
  };
  std::vector<Element> elements;
  std::string format;
  size_t pos = 0;
  int line = 0;
  for (;;) {
    const size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) return std::nullopt;  // no end_header: CGAL refuses it
    std::string l = text.substr(pos, eol - pos);
    pos = eol + 1;
    ++line;
    if (!l.empty() && l.back() == '\r') l.pop_back();
    const std::vector<Token> tok = tokenize(l);
    if (tok.empty()) continue;
    if (tok[0].text == "end_header") break;
    if (tok[0].text == "format" && tok.size() >= 2) format = std::string(tok[1].text);
    if (tok[0].text == "element") {
      long n;
      if (tok.size() != 3 || !parseLong(tok[2].text, n) || n < 0) return std::nullopt;
      elements.push_back({std::string(tok[1].text), n, {}});
    }
    if (tok[0].text == "property") {
      if (elements.empty()) return std::nullopt;
      const bool list = tok.size() == 5 && tok[1].text == "list";
      if (tok.size() != (list ? 5u : 3u)) return std::nullopt;
      const PlyType* item = plyType(tok[list ? 3 : 1].text);
      if (!item) return std::nullopt;
      Property p{std::string(tok.back().text), 0, false, item->size};
      if (list) {
        const PlyType* count = plyType(tok[2].text);
        if (!count) return std::nullopt;
        p.count_size = count->size;
        p.count_signed = count->is_signed;
      }
      elements.back().props.push_back(p);
    }
  }
  if (format == "ascii") {
    TextCursor c(text, pos, line + 1, 0);
    for (const Element& e : elements)
      for (long r = 0; r < e.count; ++r)
        for (const Property& p : e.props) {
          const std::string_view t = c.next();
          if (t.empty()) return std::nullopt;  // the file ends early: the diagnoser says where
          if (p.count_size == 0) continue;
          long k;
          if (!parseLong(t, k)) return std::nullopt;
          const std::string what = e.name + " " + std::to_string(r) + " (counting from 0)";
          if (k < 0)
            return FileProblem{c.line(), c.column(), what + ": expected the length of '" + p.name + "' (an integer >= 0), found " + quoted(std::string(t))};
          if (uint64_t(k) > c.left() / 2)
            return FileProblem{c.line(), c.column(), tooLong(what, "'" + p.name + "' of length", k, c.left())};
          for (long j = 0; j < k; ++j) c.next();
        }
    return std::nullopt;
  }
  const bool big = format == "binary_big_endian";
  if (!big && format != "binary_little_endian") return std::nullopt;
  const auto* b = reinterpret_cast<const unsigned char*>(text.data());
  size_t at = pos;
  for (const Element& e : elements)
    for (long r = 0; r < e.count; ++r)
      for (const Property& p : e.props) {
        if (p.count_size == 0) {
          if (text.size() - at < size_t(p.size)) return std::nullopt;  // truncated: CGAL says so
          at += size_t(p.size);
          continue;
        }
        if (text.size() - at < size_t(p.count_size)) return std::nullopt;
        uint64_t u = 0;
        for (int k = 0; k < p.count_size; ++k) u = u << 8 | b[at + size_t(big ? k : p.count_size - 1 - k)];
        const int bits = 8 * p.count_size;
        const long long n = p.count_signed && (u >> (bits - 1)) ? (long long)u - ((long long)1 << bits) : (long long)u;
        const std::string what = e.name + " " + std::to_string(r) + " (counting from 0), at byte " + std::to_string(at);
        at += size_t(p.count_size);
        if (n < 0) return FileProblem{0, 0, what + ": '" + p.name + "' has a negative length, " + std::to_string(n)};
        const size_t left = text.size() - at;
        if (uint64_t(n) > left / size_t(p.size)) return FileProblem{0, 0, tooLong(what, "'" + p.name + "' of length", n, left)};
        at += size_t(n) * size_t(p.size);
      }
  return std::nullopt;
}

}  // namespace dg::meshtext
